"""One drive from frames to outputs: its options and source, the streaming pipeline, the run and its steps CSV,
the benchmark."""
