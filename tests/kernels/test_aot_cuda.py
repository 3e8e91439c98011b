"""Every kernel module compiles for CUDA ahead of time (PTX for sm_90 through NVRTC, no GPU needed).

The CPU suite never runs the CUDA path; compiling it here keeps it from rotting unseen. The
per-morphology generated FK modules are compiled too, for Spot.
"""

import importlib
import pkgutil

import pytest
import warp as wp
from morphkit_testing import shipped_morphology

import morphkit.kernels
from morphkit.kernels import fk_module
from morphkit.model import compile_model


def _nvrtc_available() -> bool:
    wp.init()
    from warp._src.context import runtime

    return bool(runtime.is_cuda_enabled and runtime.nvrtc_supported_archs)


pytestmark = pytest.mark.skipif(not _nvrtc_available(), reason="this Warp build cannot compile CUDA (no NVRTC)")


def _kernel_modules() -> list[str]:
    names = []
    for info in pkgutil.iter_modules(morphkit.kernels.__path__, prefix="morphkit.kernels."):
        module = importlib.import_module(info.name)
        if wp.get_module(module.__name__).kernels:
            names.append(info.name)
    return names


KERNEL_MODULES = _kernel_modules()


def test_kernel_modules_found():
    assert {"morphkit.kernels.fk", "morphkit.kernels.end_effectors"} <= set(KERNEL_MODULES)


@pytest.mark.parametrize("name", KERNEL_MODULES)
def test_module_compiles_for_cuda(name):
    paths = wp.compile_aot_module(name, device=None, arch=90, use_ptx=True)
    assert paths and all(p.exists() and p.stat().st_size > 0 for p in paths)
    assert any(p.suffix == ".ptx" for p in paths)


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_generated_spot_fk_compiles_for_cuda(dtype):
    module = fk_module(compile_model(shipped_morphology("spot")), dtype)
    paths = wp.compile_aot_module(module, device=None, arch=90, use_ptx=True)
    assert paths and all(p.stat().st_size > 0 for p in paths)
    ptx = paths[0].read_text(errors="replace")
    assert "fk_transforms" in ptx and "fk_positions" in ptx
