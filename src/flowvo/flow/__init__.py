"""Dense optical flow: estimators selected by name, a resumable per-sequence cache, colour pictures.

Convention: ``flow_px (H, W, 2)`` float32, u right, v down, in pixels of the frames it was computed on
(see :mod:`flowvo.projection`).
"""
