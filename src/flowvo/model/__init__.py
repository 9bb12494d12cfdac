"""The learned odometry: FlowNetS-contractive network, data, training, checkpoints, inference."""
