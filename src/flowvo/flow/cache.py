"""A resumable per-sequence flow cache: float16 chunks of consecutive pairs, plus metadata.

Layout: ``CACHE/NN/<method>_s<scale>/meta.json`` and ``chunk_000000.npy`` ... each (n, H, W, 2) float16
holding pairs [k*C, k*C + n). Every chunk is written to a temporary file and renamed, then recorded in
meta.json with its size and SHA-256, so a killed run resumes at the first chunk not recorded, and a chunk
damaged or replaced afterwards is detected and recomputed. ``CACHE`` defaults to the user's cache folder
(:mod:`flowvo.flow.cache_root`), never the dataset. Plain ``.npy`` rather than zarr: no extra dependency,
memory-mapped reads, and the chunk is the unit of atomicity we need. float16 keeps flow to better than
1/16 px below 128 px (1/8 px up to 256 px), far finer than the network's input grid.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import time
from pathlib import Path

import cv2
import numpy as np

from flowvo._version import VERSION as __version__
from flowvo.errors import FlowvoError
from flowvo.flow.registry import FlowEstimator
from flowvo.io.atomic import atomic_open, write_json_atomic
from flowvo.kitti.sequence import KittiSequence
from flowvo.progress import progress

CHUNK_PAIRS = 32
MIN_FLOW_PX = 32  # OpenCV 5 DIS: below 16 px it raises; ultrafast/fast crash (SIGSEGV) on h <= 30, w >= 80
TIMING_KEYS = ("read_s", "flow_s", "pairs")
VALIDITY_KEYS = ("method", "params", "scale", "image_size_hw", "flow_size_hw", "pairs", "chunk_pairs", "frames_sha256")


def frames_fingerprint(image_paths: list[Path]) -> str:
    """SHA-256 over each frame file's name, size and modification time: changes when frames are replaced
    (e.g. a sequence rendered again), without reading the images."""
    digest = hashlib.sha256()
    for path in image_paths:
        stat = os.stat(path)
        digest.update(f"{path.name} {stat.st_size} {stat.st_mtime_ns}\n".encode())
    return digest.hexdigest()


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def resize_frame(image: np.ndarray, scale: float) -> np.ndarray:
    """Frame at the working resolution (area interpolation when shrinking)."""
    if scale == 1.0:
        return image
    h, w = image.shape[:2]
    size = (int(round(w * scale)), int(round(h * scale)))
    return cv2.resize(image, size, interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR)


class FlowCache:
    """Flow of every consecutive pair of one sequence, for one method and working scale.

    ``meta.json`` records what the flow depends on (method, parameters, scale, sizes, and a fingerprint of
    the frame files: names, sizes, modification times) and, per chunk, its pair count, byte size and
    SHA-256. A cache made for other inputs is stale: :meth:`compute` discards it and starts over. A chunk
    that is missing, truncated, of another shape (e.g. copied from another scale) or whose checksum does
    not match is recomputed; :meth:`read_range` refuses such a chunk instead of returning wrong flow.
    """

    def __init__(self, cache_root: str | Path, sequence: KittiSequence, method: str, scale: float,
                 params: dict | None = None) -> None:
        sequence.require_frames(2, "optical flow")
        self.sequence = sequence
        h, w = sequence.image_size_hw
        if not (math.isfinite(scale) and scale > 0) or min(round(h * scale), round(w * scale)) < MIN_FLOW_PX:
            raise FlowvoError(f"flow scale {scale:g} of {w}x{h} frames: need a positive scale giving at least "
                              f"{MIN_FLOW_PX} pixels a side")
        self.directory = Path(cache_root) / sequence.sequence / f"{method}_s{scale:g}"
        self.flow_size_hw = (int(round(h * scale)), int(round(w * scale)))
        self.metadata = {
            "method": method,
            "params": params or {},
            "scale": scale,
            "image_size_hw": list(sequence.image_size_hw),
            "flow_size_hw": list(self.flow_size_hw),
            "pairs": len(sequence) - 1,
            "chunk_pairs": CHUNK_PAIRS,
            "frames_sha256": frames_fingerprint(sequence.image_paths),
            "flow_units": "pixels of the flow_size_hw frame; u right, v down; pair i = frame i -> i+1",
            "dtype": "float16",
            "flowvo_version": __version__,
        }
        self.stale_reason, self.chunks = self._check_existing()

    @property
    def meta_path(self) -> Path:
        return self.directory / "meta.json"

    def _check_existing(self) -> tuple[str | None, dict[str, dict]]:
        """Why the cache on disk cannot be used (None when it can), and its chunk records."""
        if not self.meta_path.is_file():
            return None, {}
        try:
            stored = json.loads(self.meta_path.read_text())
        except (OSError, ValueError):
            return "its meta.json is unreadable", {}
        if not isinstance(stored, dict) or not isinstance(stored.get("chunks"), dict):
            return "its meta.json has no chunk records", {}
        for key in VALIDITY_KEYS:
            if stored.get(key) != self.metadata[key]:
                return f"it was made with {key}={stored.get(key)!r}, this run needs {self.metadata[key]!r}", {}
        return None, stored["chunks"]

    @property
    def n_pairs(self) -> int:
        return len(self.sequence) - 1

    @property
    def n_chunks(self) -> int:
        return -(-self.n_pairs // CHUNK_PAIRS)

    def chunk_path(self, chunk: int) -> Path:
        return self.directory / f"chunk_{chunk:06d}.npy"

    def _chunk_shape(self, chunk: int) -> tuple[int, int, int, int]:
        pairs = min(CHUNK_PAIRS, self.n_pairs - chunk * CHUNK_PAIRS)
        return (pairs, *self.flow_size_hw, 2)

    def chunk_problem(self, chunk: int, verify_checksum: bool = False) -> str | None:
        """Why chunk ``chunk`` cannot be used ("missing", "truncated", ...), or None when it is sound."""
        path = self.chunk_path(chunk)
        record = self.chunks.get(f"{chunk:06d}")
        if self.stale_reason is not None or not path.is_file():
            return "missing"
        if not isinstance(record, dict):
            return "not recorded in meta.json"
        if path.stat().st_size != record.get("bytes"):
            return f"{path.stat().st_size} bytes, meta.json records {record.get('bytes')}"
        try:
            data = np.load(path, mmap_mode="r")
        except (OSError, ValueError, EOFError):
            return "not a readable .npy file"
        if data.shape != self._chunk_shape(chunk) or data.dtype != np.float16:
            return f"holds {data.dtype} {data.shape}, expected float16 {self._chunk_shape(chunk)}"
        if verify_checksum and _sha256(path) != record.get("sha256"):
            return "checksum differs from meta.json"
        return None

    def missing_chunks(self, verify_checksums: bool = False) -> list[int]:
        """Chunks to (re)compute: missing or damaged (size, shape, dtype; checksum when asked)."""
        return [k for k in range(self.n_chunks) if self.chunk_problem(k, verify_checksums) is not None]

    @property
    def complete(self) -> bool:
        """Every chunk present with the recorded size and the expected shape (checksums: see compute)."""
        return not self.missing_chunks()

    def _write_meta(self) -> None:
        write_json_atomic(self.meta_path, {**self.metadata, "chunks": self.chunks})

    def _start(self) -> None:
        """Create the folder, discard a stale cache's chunks and timing, record the metadata."""
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise FlowvoError(f"cannot create the flow cache folder ({error.strerror}); give a writable --cache",
                              self.directory) from None
        if self.stale_reason is not None:
            for path in [*self.directory.glob("chunk_*.npy"), self.timing_path]:
                path.unlink(missing_ok=True)
            self.stale_reason, self.chunks = None, {}
        self._write_meta()

    def compute(self, estimator: FlowEstimator, stop_after_chunks: int | None = None) -> dict:
        """Fill every missing or damaged chunk (checksums verified); returns seconds spent reading frames
        and estimating flow, the pairs computed, the chunks ``replaced`` because they were damaged, and
        ``discarded``: why an earlier cache for other inputs was thrown away (or None).

        A sound, complete cache is only read (it may be read-only). ``stop_after_chunks`` ends early after
        that many chunks (used to simulate an interrupted run).
        """
        timing = {"read_s": 0.0, "flow_s": 0.0, "pairs": 0, "replaced": 0, "discarded": self.stale_reason}
        missing = self.missing_chunks(verify_checksums=True)  # every chunk of a stale cache
        if stop_after_chunks is not None:
            missing = missing[:stop_after_chunks]
        if not missing:
            return timing
        self._start()
        total = sum(self._chunk_shape(k)[0] for k in missing)
        bar = progress(range(total), f"flow {self.sequence.sequence} {self.metadata['method']}", total, "pair")
        for chunk in missing:
            timing["replaced"] += int(self.chunk_path(chunk).is_file())
            self.chunks.pop(f"{chunk:06d}", None)
            flows = self._estimate_chunk(estimator, chunk, timing, bar)
            buffer = io.BytesIO()
            np.save(buffer, flows)
            payload = buffer.getvalue()
            with atomic_open(self.chunk_path(chunk), "wb") as handle:
                handle.write(payload)
            self.chunks[f"{chunk:06d}"] = {"pairs": len(flows), "bytes": len(payload),
                                           "sha256": hashlib.sha256(payload).hexdigest()}
            self._write_meta()
            timing["pairs"] += len(flows)
        if timing["pairs"]:
            self._record_timing(timing)
        return timing

    def _estimate_chunk(self, estimator: FlowEstimator, chunk: int, timing: dict, bar) -> np.ndarray:
        first = chunk * CHUNK_PAIRS
        flows = np.empty(self._chunk_shape(chunk), np.float16)
        start = time.perf_counter()
        previous = resize_frame(self.sequence.read_image(first), self.metadata["scale"])
        timing["read_s"] += time.perf_counter() - start
        for k in range(len(flows)):
            start = time.perf_counter()
            current = resize_frame(self.sequence.read_image(first + k + 1), self.metadata["scale"])
            middle = time.perf_counter()
            flows[k] = estimator.estimate(previous, current)
            timing["flow_s"] += time.perf_counter() - middle
            timing["read_s"] += middle - start
            previous = current
            next(bar, None)
        return flows

    @property
    def timing_path(self) -> Path:
        return self.directory / "timing.json"

    def _record_timing(self, timing: dict) -> None:
        totals = self.recorded_timing() or {"read_s": 0.0, "flow_s": 0.0, "pairs": 0}
        for key in TIMING_KEYS:
            totals[key] += timing[key]
        write_json_atomic(self.timing_path, totals)

    def recorded_timing(self) -> dict | None:
        """Seconds spent reading frames and estimating flow over all runs that filled this cache."""
        try:
            recorded = json.loads(self.timing_path.read_text())
        except (OSError, ValueError):  # absent, or damaged: timing is a note, never worth failing a run for
            return None
        if not isinstance(recorded, dict) or not all(isinstance(recorded.get(k), (int, float)) for k in TIMING_KEYS):
            return None
        return {key: recorded[key] for key in TIMING_KEYS}

    def read(self, pair: int) -> np.ndarray:
        """Flow of pair ``pair`` (frame pair -> pair+1), float32 (H, W, 2)."""
        return self.read_range(pair, pair + 1)[0]

    def read_range(self, first: int, last: int) -> np.ndarray:
        """Flows of pairs [first, last) as float32 (n, H, W, 2)."""
        if not 0 <= first < last <= self.n_pairs:
            raise IndexError(f"pairs [{first}, {last}) outside 0..{self.n_pairs}")
        parts = []
        for chunk in range(first // CHUNK_PAIRS, (last - 1) // CHUNK_PAIRS + 1):
            problem = self.chunk_problem(chunk)
            if problem is not None:
                raise FlowvoError(f"flow cache chunk unusable ({problem}); run 'flowvo flow' to recompute it",
                                  self.chunk_path(chunk))
            data = np.load(self.chunk_path(chunk), mmap_mode="r")
            lo = max(first - chunk * CHUNK_PAIRS, 0)
            hi = min(last - chunk * CHUNK_PAIRS, len(data))
            parts.append(np.asarray(data[lo:hi], dtype=np.float32))
        return np.concatenate(parts)
