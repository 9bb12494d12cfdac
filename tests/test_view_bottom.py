"""Where the view ends (flowvo.odometry.view_bottom.ViewBottom): over a scene that changes from frame to frame, a still
band across the bottom rows (a bonnet) is placed to the row by the frames' mean image, once the still tracks tell
that a band is there, and the view ends a row above its edge for good."""

import numpy as np

from flowvo.odometry.view_bottom import ViewBottom

HW = (188, 620)
EDGE = 173  # the bonnet's first row
rng = np.random.default_rng(5)
PAINT = rng.uniform(150, 200, HW)  # the bonnet's texture, the same in every frame


def frame(edge: int = EDGE) -> np.ndarray:
    """A frame of road texture that is new in every frame, over the bonnet's paint from row ``edge`` down."""
    image = rng.uniform(0, 120, HW)
    image[edge:] = PAINT[: HW[0] - edge]
    return image.astype(np.uint8)


def test_the_view_ends_a_row_above_the_bonnet_edge_once_a_band_is_found_and_stays():
    view = ViewBottom(HW, first_row=139.6, cell_px=16.0)
    for _ in range(12):
        view.observe(frame())
    assert view.settle(None) == HW[0] and view.frame_row(376) is None  # no band told: the whole frame
    assert view.settle(176) == EDGE - 1  # the band's top cell row (176) places the edge within a cell
    assert view.frame_row(376) == 2 * (EDGE - 1)  # in frames twice the working height
    view.observe(frame(150))
    assert view.settle(160) == EDGE - 1  # found once, it stays


def test_a_band_told_before_any_frame_places_nothing():
    view = ViewBottom(HW, first_row=139.6, cell_px=16.0)
    assert view.settle(176) == HW[0] and not view.found
