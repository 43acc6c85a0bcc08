"""Python tools of ekf_vislam: dataset loading, simulation, trajectories and evaluation."""
