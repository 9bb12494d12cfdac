"""Regions that do not move with the scene (flowvo.odometry.still_regions): a bonnet in the bottom rows is found
from points that stand still while the rest moves, a car that drove along and then fell behind is let go again,
and nothing is judged while the whole scene stands still or above the first judged row."""

import numpy as np

from flowvo.odometry.still_regions import MIN_STEPS, StillRegions

HW = (188, 620)
GRID = np.stack(np.meshgrid(np.arange(8.0, 612.0, 8.0), np.arange(100.0, 184.0, 8.0)), axis=-1).reshape(-1, 2)
BONNET = GRID[:, 1] >= 160  # the bottom rows: a bonnet


def observe_steps(regions, count, motion_px):
    changed = [regions.observe(GRID, motion_px) for _ in range(count)]
    return any(changed)


def test_a_bonnet_that_stands_still_while_the_road_moves_is_left_out():
    regions = StillRegions(HW, first_row=120)
    motion = np.where(BONNET, 0.05, 3.0)
    assert not observe_steps(regions, MIN_STEPS - 1, motion)  # not judged before MIN_STEPS steps
    assert observe_steps(regions, 1, motion)
    keep = regions.keep(GRID)
    np.testing.assert_array_equal(keep, ~BONNET)
    assert regions.still_cells > 0


def test_nothing_is_judged_while_the_scene_stands_still_or_above_the_first_row():
    regions = StillRegions(HW, first_row=120)
    observe_steps(regions, 3 * MIN_STEPS, np.full(len(GRID), 0.1))  # a standstill: everything still, nothing learnt
    assert regions.keep(GRID).all()
    high = StillRegions(HW, first_row=176)  # the bonnet's rows start above the first judged row but one
    observe_steps(high, 3 * MIN_STEPS, np.where(BONNET, 0.05, 3.0))
    assert (~high.keep(GRID)).sum() == (GRID[:, 1] >= 176).sum()


def test_a_car_that_drove_along_and_fell_behind_is_let_go():
    regions = StillRegions(HW, first_row=120)
    along = np.where(BONNET, 0.05, 3.0)
    observe_steps(regions, 2 * MIN_STEPS, along)
    assert not regions.keep(GRID).all()
    observe_steps(regions, 4 * MIN_STEPS, np.full(len(GRID), 3.0))  # the same cells move with the road again
    assert regions.keep(GRID).all() and regions.still_cells == 0


def test_a_bonnet_band_seen_in_some_of_its_cells_keeps_its_rows_and_everything_below_them_out():
    """Points on a bonnet are found in only some of its cells: with ``band`` (the tracks' regions), a row of cells a
    quarter of which stand still is left out whole, and so is every cell below a still one; without it, only the
    still cells. A single still cell higher up (a watermark) leaves out its column below it, not its row."""
    seen = BONNET & (GRID[:, 0] < 192)  # a third of the bonnet's width (12 of 39 cells of 16 px) carries points
    watermark = (GRID[:, 1] >= 128) & (GRID[:, 1] < 144) & (GRID[:, 0] >= 304) & (GRID[:, 0] < 320)  # one cell
    points = seen | watermark | ~BONNET
    motion = np.where(seen | watermark, 0.05, 3.0)[points]
    band, plain = StillRegions(HW, first_row=120, band=True), StillRegions(HW, first_row=120)
    for regions in (band, plain):
        for _ in range(MIN_STEPS):
            regions.observe(GRID[points], motion)
    np.testing.assert_array_equal(~plain.keep(GRID), seen | watermark)
    below_watermark = (GRID[:, 0] >= 304) & (GRID[:, 0] < 320) & (GRID[:, 1] >= 128)
    np.testing.assert_array_equal(~band.keep(GRID), BONNET | below_watermark)
    assert band.still_cells == plain.still_cells  # what stands still is counted alike


def test_widen_takes_the_four_neighbours_of_each_still_cell():
    regions = StillRegions(HW, first_row=0)
    regions.still = np.zeros(regions.shape, bool)
    regions.still[5, 7] = regions.still[11, 0] = True  # one inside, one on the bottom-left edge
    regions.still = regions.still.ravel()
    regions.widen()
    expected = np.zeros(regions.shape, bool)
    for r, c in [(5, 7), (4, 7), (6, 7), (5, 6), (5, 8), (11, 0), (10, 0), (11, 1)]:
        expected[r, c] = True
    np.testing.assert_array_equal(regions.still.reshape(regions.shape), expected)
    np.testing.assert_array_equal(regions.kept_out, regions.still)


def test_a_bonnet_band_tells_where_it_begins_and_a_watermark_or_still_cells_alone_do_not():
    """The tracks' band (``band``): the first pixel row of the rows kept out across the whole width that reach the
    frame's bottom, the bonnet's top cell row (160 = 10 cells of 16 px); a watermark keeps out only its column, and
    without ``band`` the bonnet's still cells (a third of its width) are no band."""
    seen = BONNET & (GRID[:, 0] < 192)
    watermark = (GRID[:, 1] >= 128) & (GRID[:, 1] < 144) & (GRID[:, 0] >= 304) & (GRID[:, 0] < 320)
    band, plain, marked = (StillRegions(HW, first_row=120, band=True), StillRegions(HW, first_row=120),
                           StillRegions(HW, first_row=120, band=True))
    assert band.band_top_px() is None  # nothing judged yet
    for _ in range(MIN_STEPS):
        band.observe(GRID, np.where(seen | watermark, 0.05, 3.0))
        plain.observe(GRID, np.where(seen, 0.05, 3.0))
        marked.observe(GRID, np.where(watermark, 0.05, 3.0))
    assert band.band_top_px() == 160
    assert plain.band_top_px() is None and plain.still_cells > 0
    assert marked.band_top_px() is None and marked.still_cells == 1
