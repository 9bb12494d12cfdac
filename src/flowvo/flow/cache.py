"""A resumable per-sequence flow cache: float16 chunks of consecutive pairs, plus metadata.

Layout: ``CACHE/NN/<method>_s<scale>/meta.json`` and ``chunk_000000.npy`` ... each (n, H, W, 2) float16
holding pairs [k*C, k*C + n). Every chunk is written to a temporary file and renamed, so a chunk that
exists is complete; a killed run resumes at the first missing chunk. Plain ``.npy`` rather than zarr: no
extra dependency, memory-mapped reads, and the chunk is the unit of atomicity we need. float16 keeps
flow to better than 1/16 px below 128 px (1/8 px up to 256 px), far finer than the network's input grid.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import cv2
import numpy as np

from flowvo import __version__
from flowvo.atomic import atomic_path, write_json_atomic
from flowvo.errors import FlowvoError
from flowvo.flow.registry import FlowEstimator
from flowvo.kitti.sequence import KittiSequence
from flowvo.progress import progress

CHUNK_PAIRS = 32


def resize_frame(image: np.ndarray, scale: float) -> np.ndarray:
    """Frame at the working resolution (area interpolation when shrinking)."""
    if scale == 1.0:
        return image
    h, w = image.shape[:2]
    size = (int(round(w * scale)), int(round(h * scale)))
    return cv2.resize(image, size, interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR)


class FlowCache:
    """Flow of every consecutive pair of one sequence, for one method and working scale."""

    def __init__(self, cache_root: str | Path, sequence: KittiSequence, method: str, scale: float,
                 params: dict | None = None) -> None:
        self.sequence = sequence
        self.directory = Path(cache_root) / sequence.sequence / f"{method}_s{scale:g}"
        h, w = sequence.image_size_hw
        self.flow_size_hw = (int(round(h * scale)), int(round(w * scale)))
        self.metadata = {
            "method": method,
            "params": params or {},
            "scale": scale,
            "image_size_hw": list(sequence.image_size_hw),
            "flow_size_hw": list(self.flow_size_hw),
            "pairs": len(sequence) - 1,
            "chunk_pairs": CHUNK_PAIRS,
            "flow_units": "pixels of the flow_size_hw frame; u right, v down; pair i = frame i -> i+1",
            "dtype": "float16",
            "flowvo_version": __version__,
        }
        self._check_existing()

    @property
    def meta_path(self) -> Path:
        return self.directory / "meta.json"

    def _check_existing(self) -> None:
        if not self.meta_path.is_file():
            return
        try:
            stored = json.loads(self.meta_path.read_text())
        except json.JSONDecodeError:
            raise FlowvoError("flow cache metadata is not valid JSON; delete the folder", self.meta_path) from None
        for key in ("method", "params", "scale", "image_size_hw", "flow_size_hw", "pairs", "chunk_pairs"):
            if stored.get(key) != self.metadata[key]:
                raise FlowvoError(
                    f"flow cache was made with {key}={stored.get(key)!r}, this run needs {self.metadata[key]!r}; "
                    "use another --cache folder or delete this one",
                    self.meta_path,
                )

    @property
    def n_pairs(self) -> int:
        return len(self.sequence) - 1

    @property
    def n_chunks(self) -> int:
        return -(-self.n_pairs // CHUNK_PAIRS)

    def chunk_path(self, chunk: int) -> Path:
        return self.directory / f"chunk_{chunk:06d}.npy"

    def missing_chunks(self) -> list[int]:
        return [k for k in range(self.n_chunks) if not self.chunk_path(k).is_file()]

    @property
    def complete(self) -> bool:
        return not self.missing_chunks()

    def compute(self, estimator: FlowEstimator, stop_after_chunks: int | None = None) -> dict[str, float]:
        """Fill every missing chunk; returns seconds spent reading frames and estimating flow.

        ``stop_after_chunks`` ends early after that many chunks (used to simulate an interrupted run).
        """
        self.directory.mkdir(parents=True, exist_ok=True)
        write_json_atomic(self.meta_path, self.metadata)
        timing = {"read_s": 0.0, "flow_s": 0.0, "pairs": 0}
        missing = self.missing_chunks()
        if stop_after_chunks is not None:
            missing = missing[:stop_after_chunks]
        total = sum(min(CHUNK_PAIRS, self.n_pairs - k * CHUNK_PAIRS) for k in missing)
        bar = progress(range(total), f"flow {self.sequence.sequence} {self.metadata['method']}", total, "pair")
        for chunk in missing:
            first = chunk * CHUNK_PAIRS
            last = min(first + CHUNK_PAIRS, self.n_pairs)
            flows = np.empty((last - first, *self.flow_size_hw, 2), np.float16)
            start = time.perf_counter()
            previous = resize_frame(self.sequence.read_image(first), self.metadata["scale"])
            timing["read_s"] += time.perf_counter() - start
            for k, index in enumerate(range(first, last)):
                start = time.perf_counter()
                current = resize_frame(self.sequence.read_image(index + 1), self.metadata["scale"])
                middle = time.perf_counter()
                flows[k] = estimator.estimate(previous, current)
                timing["flow_s"] += time.perf_counter() - middle
                timing["read_s"] += middle - start
                previous = current
                next(bar, None)
            with atomic_path(self.chunk_path(chunk)) as tmp:
                np.save(tmp, flows)
            timing["pairs"] += last - first
        if timing["pairs"]:
            self._record_timing(timing)
        return timing

    @property
    def timing_path(self) -> Path:
        return self.directory / "timing.json"

    def _record_timing(self, timing: dict) -> None:
        totals = self.recorded_timing() or {"read_s": 0.0, "flow_s": 0.0, "pairs": 0}
        for key in ("read_s", "flow_s", "pairs"):
            totals[key] += timing[key]
        write_json_atomic(self.timing_path, totals)

    def recorded_timing(self) -> dict | None:
        """Seconds spent reading frames and estimating flow over all runs that filled this cache."""
        if not self.timing_path.is_file():
            return None
        return json.loads(self.timing_path.read_text())

    def read(self, pair: int) -> np.ndarray:
        """Flow of pair ``pair`` (frame pair -> pair+1), float32 (H, W, 2)."""
        return self.read_range(pair, pair + 1)[0]

    def read_range(self, first: int, last: int) -> np.ndarray:
        """Flows of pairs [first, last) as float32 (n, H, W, 2)."""
        if not 0 <= first < last <= self.n_pairs:
            raise IndexError(f"pairs [{first}, {last}) outside 0..{self.n_pairs}")
        parts = []
        for chunk in range(first // CHUNK_PAIRS, (last - 1) // CHUNK_PAIRS + 1):
            path = self.chunk_path(chunk)
            if not path.is_file():
                raise FlowvoError("flow cache chunk missing; run 'flowvo flow' to complete the cache", path)
            data = np.load(path, mmap_mode="r")
            lo = max(first - chunk * CHUNK_PAIRS, 0)
            hi = min(last - chunk * CHUNK_PAIRS, len(data))
            parts.append(np.asarray(data[lo:hi], dtype=np.float32))
        return np.concatenate(parts)
