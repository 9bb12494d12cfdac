"""The reference system (2016) that flowvo is measured against: its published figures on real KITTI."""

REFERENCE_LABEL = "reference system (2016), published"
REFERENCE_FIGURES = {  # sequence -> (t_err %, r_err deg/m), as published; 10 alone was not given
    "08": (9.98, 0.0544),
    "09": (12.64, 0.0804),
    "average 08-10": (10.77, 0.0623),
}
REFERENCE_SECONDS_PER_FRAME = 0.633  # published, on a GPU
