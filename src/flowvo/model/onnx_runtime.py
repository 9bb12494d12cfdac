"""Run an exported ``.onnx`` odometry model with ONNX Runtime, the same way as the PyTorch module.

:class:`OnnxOdometry` mirrors :class:`flowvo.model.deployable.DeployableOdometry`: ``input_hw``,
``stack``, ``head``, ``output_names`` and ``predict`` (flow (B, 2K, h, w) in pixels -> motion (B, D)
float64 in metres and radians), so a streaming loop can take either. Needs the optional ``onnxruntime``
package (``pip install 'flowvo[export]'``), and not torch.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from flowvo.errors import FlowvoError
from flowvo.model.export_format import FORMAT, INPUT_NAME, METADATA_KEY
from flowvo.optional import import_optional


class OnnxOdometry:
    """An exported odometry model on ONNX Runtime's CPU provider.

    ``intra_op_threads``: threads one inference may use; 0 lets ONNX Runtime choose. Default 1, so that on
    a small CPU the flow estimator and the network do not fight over cores.
    """

    def __init__(self, path: str | Path, intra_op_threads: int = 1) -> None:
        ort = import_optional("onnxruntime", "running an ONNX model", "export")
        path = Path(path)
        if not path.is_file():
            raise FlowvoError("ONNX model not found", path)
        options = ort.SessionOptions()
        options.intra_op_num_threads = intra_op_threads
        options.inter_op_num_threads = 1
        try:
            self.session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
        except Exception as error:  # onnxruntime raises its own exception types for foreign or corrupt files
            raise FlowvoError(f"cannot load as an ONNX model ({type(error).__name__})", path) from None
        stored = self.session.get_modelmeta().custom_metadata_map.get(METADATA_KEY)
        self.description = json.loads(stored) if stored else {}
        if self.description.get("format") != FORMAT:
            raise FlowvoError(f"not a flowvo odometry export (no {FORMAT} description in its metadata)", path)

    @property
    def input_hw(self) -> tuple[int, int]:
        """Network input (height, width) in pixels."""
        h, w = self.description["input_hw"]
        return int(h), int(w)

    @property
    def stack(self) -> int:
        """K, the number of consecutive flow fields in the input (2K channels)."""
        return int(self.description["stack"])

    @property
    def head(self) -> str:
        """"planar" (distance, heading change) or "se3" (translation, axis-angle)."""
        return str(self.description["head"])

    @property
    def output_names(self) -> tuple[str, ...]:
        """Names of the D output components, units in the suffix (``distance_m``, ``heading_rad``, ...)."""
        return tuple(self.description["output"]["components"])

    def predict(self, flow_px: np.ndarray) -> np.ndarray:
        """Motion (B, D) float64 (m, rad) of flow (B, 2K, h, w) in pixels of the network input."""
        inputs = np.ascontiguousarray(flow_px, dtype=np.float32)
        return self.session.run(None, {INPUT_NAME: inputs})[0].astype(np.float64)
