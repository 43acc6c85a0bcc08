"""Locating the package's built executables (for the benchmark and soak drivers)."""
import os
import subprocess


def vislam_offline_path():
    """Path of the built vislam_offline executable, or None when it is not built."""
    libexec = subprocess.run(['catkin_find', '--first-only', '--libexec', 'ekf_vislam'],
                             capture_output=True, text=True).stdout.strip()
    path = os.path.join(libexec, 'vislam_offline')
    return path if libexec and os.path.exists(path) else None
