# Installs the ekf_vislam_tools Python package (shared by the scripts); do not run directly.
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(packages=['ekf_vislam_tools'], package_dir={'': 'src'}))
