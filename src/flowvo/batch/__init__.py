"""Many drives at once: ``flowvo batch`` as a library.

``discover_drives`` turns paths, globs and manifests into uniquely named drives.
"""

from flowvo.batch.discover import discover_drives
from flowvo.batch.spec import Drive

__all__ = ["Drive", "discover_drives"]
