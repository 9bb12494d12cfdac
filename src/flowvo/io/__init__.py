"""Files in and out: atomic writes, the run's output files, numbers in text files, PyTorch files."""
