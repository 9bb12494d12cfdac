"""Many drives at once: ``flowvo batch`` as a library.

``discover_drives`` turns paths, globs and manifests into uniquely named drives; ``run_batch`` runs them
(local worker processes or Ray) into one output folder with a fleet summary, resuming earlier work;
``run_drive`` runs one drive in the calling process, for schedulers of one's own (Dask, a Ray job).
"""

from flowvo.batch.discover import discover_drives
from flowvo.batch.fleet import run_batch
from flowvo.batch.record import DriveSummary
from flowvo.batch.spec import Drive
from flowvo.batch.summary import batch_totals, write_summary
from flowvo.batch.worker import run_drive

__all__ = ["Drive", "DriveSummary", "batch_totals", "discover_drives", "run_batch", "run_drive", "write_summary"]
