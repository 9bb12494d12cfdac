"""The default method's engine: rotation and direction from tracked points (two-view geometry and its checks),
the road plane and its key frames, the scale window and the speed prior, the bundle stage, the uncertainty.
``flowvo.methods.flowvo`` wires these stages into the per-frame step; nothing here reads files or prints."""
