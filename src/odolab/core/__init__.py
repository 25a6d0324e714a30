"""odolab's core: the vocabulary and the maths (kinematics, odometry, encoders, parameters,
models, trials, trajectories, uncertainty, errors, text and number formatting, and the
compiled kernels). It imports nothing above it: every other package builds on it."""
