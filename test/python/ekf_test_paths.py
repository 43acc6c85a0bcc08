"""Paths and small helpers shared by the Python tests: repository root, scripts, the data
directory (env EKF_VISLAM_DATA, else <repo>/../shared/data), temporary directories, npz files
and running a script of the package as a subprocess with Debian's python3, or vislam_offline."""
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

PYTHON = '/usr/bin/python3'
REPO_ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), '..', '..'))
SCRIPTS_DIR = os.path.join(REPO_ROOT, 'scripts')
SOURCE_DIR = os.path.join(REPO_ROOT, 'src')

# Fallback for an unsourced shell: the sourced workspace (devel space, first on sys.path) wins.
if SOURCE_DIR not in sys.path:
    sys.path.append(SOURCE_DIR)


def data_dir():
    """The shared data directory, or None when it is absent (tests using it are skipped)."""
    path = os.environ.get('EKF_VISLAM_DATA') or os.path.join(REPO_ROOT, '..', 'shared', 'data')
    path = os.path.abspath(path)
    return path if os.path.isdir(path) else None


def data_file(*parts):
    """A file under the data directory, or None when the directory or the file is absent."""
    root = data_dir()
    if root is None:
        return None
    path = os.path.join(root, *parts)
    return path if os.path.exists(path) else None


def make_temp_dir(testcase=None, prefix='ekf_vislam_test_'):
    """A fresh temporary directory; removed at the end of the test when a TestCase is given
    (otherwise the caller removes it, e.g. with addClassCleanup)."""
    path = tempfile.mkdtemp(prefix=prefix)
    if testcase is not None:
        testcase.addCleanup(shutil.rmtree, path, True)
    return path


def simulated_drive(test_class, *simulator_args, name='sim'):
    """For a TestCase's setUpClass: a temporary directory (removed after the class) holding a
    drive of simulate_dataset.py with `simulator_args` -> (directory, PREFIX of its files)."""
    directory = make_temp_dir()
    test_class.addClassCleanup(remove_dir, directory)
    prefix = os.path.join(directory, name)
    proc = run_script('simulate_dataset.py', *simulator_args, '--out', prefix)
    if proc.returncode != 0:
        raise RuntimeError('simulate_dataset.py failed: %s' % proc.stderr)
    return directory, prefix


def write_npz(directory, name, arrays):
    """Writes `arrays` as DIRECTORY/NAME (an uncompressed npz) and returns the path."""
    path = os.path.join(directory, name)
    np.savez(path, **arrays)
    return path


def remove_dir(path):
    shutil.rmtree(path, ignore_errors=True)


def script_env():
    """The current environment (a sourced workspace), with the package's src/ as a fallback on
    PYTHONPATH so ekf_vislam_tools is found even from an unsourced shell."""
    env = dict(os.environ)
    parts = [p for p in env.get('PYTHONPATH', '').split(os.pathsep) if p]
    if SOURCE_DIR not in parts:
        parts.append(SOURCE_DIR)
    env['PYTHONPATH'] = os.pathsep.join(parts)
    return env


def run_script(name, *args, timeout=300, env=None):
    """Run scripts/<name> with /usr/bin/python3 -> CompletedProcess (text stdout/stderr)."""
    return subprocess.run([PYTHON, os.path.join(SCRIPTS_DIR, name)] + [str(a) for a in args],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True,
                          timeout=timeout, env=env or script_env())


def run_vislam_offline(bag, out_dir, *args, timeout=600):
    """rosrun ekf_vislam vislam_offline --bag BAG --out OUT_DIR ARGS -> CompletedProcess (text
    stdout/stderr); the caller checks the return code."""
    return subprocess.run(['rosrun', 'ekf_vislam', 'vislam_offline', '--bag', str(bag), '--out',
                           str(out_dir)] + [str(a) for a in args], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, universal_newlines=True, timeout=timeout)
