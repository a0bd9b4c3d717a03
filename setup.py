"""`pip install .` (or `pip wheel .`): builds the fdv Python extension with the project's own CMake
build and installs the `fdv` package (docs/PYTHON.md, "pip"). Offline, with Debian's setuptools:

    /usr/bin/python3 -m venv --system-site-packages V
    V/bin/pip install --no-index --no-build-isolation .

The CMake build folder is build-pip/ unless FDV_PIP_BUILD_DIR names another (an existing Release
build such as build/ is reused: only the extension target is built). CMAKE_BUILD_PARALLEL_LEVEL
sets the jobs (default: every core).
"""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent
VERSION = re.search(r"project\(\w+ VERSION ([0-9.]+)", (ROOT / "CMakeLists.txt").read_text()).group(1)


class CMakeBuild(build_ext):
    """Builds the extension target `fdv_python` and copies the module where setuptools wants it."""

    def build_extension(self, ext):
        build = Path(os.environ.get("FDV_PIP_BUILD_DIR", ROOT / "build-pip")).resolve()
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 2))
        if not (build / "CMakeCache.txt").exists():
            subprocess.run(["cmake", "-S", str(ROOT), "-B", str(build), "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
                            "-DFDV_BUILD_TESTS=OFF", "-DFDV_BUILD_BENCH=OFF",
                            f"-DPython_EXECUTABLE={sys.executable}"], check=True)
        subprocess.run(["cmake", "--build", str(build), "-j", jobs, "--target", "fdv_python"], check=True)
        built = sorted((build / "python" / "fdv").glob("_fdv*.so"))
        if not built:
            sys.exit(f"fdv: the CMake build in {build} made no python/fdv/_fdv*.so")
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(built[0], target)
        # The format plugins (HDF5, ROS 1 bags), loaded from fdv_plugins/ beside the extension.
        plugins = target.parent / "fdv_plugins"
        plugins.mkdir(exist_ok=True)
        for plugin in sorted((build / "fdv_plugins").glob("libfdv_*.so")):
            shutil.copy(plugin, plugins)


setup(
    name="fdv",
    version=VERSION,
    description="Event camera + depth + IMU perception of fast objects (FAST-Dynamic-Vision), Python API",
    packages=["fdv"],
    package_dir={"fdv": "python/fdv"},
    ext_modules=[Extension("fdv._fdv", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    python_requires=">=3.9",
    install_requires=["numpy"],
    # setuptools' own scratch, away from the CMake build folders
    options={"build": {"build_base": "build-pip/setuptools"}, "egg_info": {"egg_base": "build-pip"}},
)
