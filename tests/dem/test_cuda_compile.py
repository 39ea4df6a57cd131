"""The CUDA kernels compile for a real GPU (PTX for sm_90), without one.

The CUDA simulator runs the kernels as Python and calls the CPU-compiled bodies, so it never
types the CUDA path: from the containers refactor (632c2ad) until this test, the kernels did not
compile on a GPU (a named-tuple field called ``index`` typed as ``tuple.index``), and every
simulator test passed. numba-cuda types and lowers a kernel with NVVM and no device, so this
test compiles each kernel of a time step, with the argument types of a real simulation's arrays
in the device layout, as the GPU backend launches them.
"""

from __future__ import annotations

import importlib
import types

import numba
import numpy as np
import pytest
from worlds import random_world, table

from demcal.dem.containers import KEYS, EngineState, Neighbors, Params, pack
from demcal.dem.materials import Interaction
from demcal.dem.simulation import Simulation


def _world(gamma: float):
    """tests/dem/worlds.random_world: spheres, stalks and an odd clump against a plate, a
    slope and a tube (every kind of contact), dry or with JKR cohesion."""
    return random_world(np.random.default_rng(0), table(Interaction(0.3, 0.5, 0.1, gamma)))


@pytest.fixture(scope="module")
def kernels():
    """The backend's kernels, with device functions compiled for sm_90 (no GPU needed)."""
    pytest.importorskip("numba_cuda", reason="numba-cuda is not installed")
    from numba import cuda

    from demcal.dem.backends import cuda as backend

    dispatcher = importlib.import_module(cuda.__name__ + ".dispatcher")
    saved = dispatcher.get_current_device
    # device functions ask the current device for its compute capability; there is none here
    dispatcher.get_current_device = lambda: types.SimpleNamespace(compute_capability=(9, 0))
    try:
        cuda.compile_ptx(lambda a: None, (numba.float64[:],), cc=(9, 0))
    except Exception as exc:  # NVVM or NVRTC missing: say so
        dispatcher.get_current_device = saved
        pytest.skip(f"numba-cuda cannot compile PTX here: {str(exc).splitlines()[0]}")
    yield backend, backend._build_kernels(), cuda
    dispatcher.get_current_device = saved


@pytest.mark.parametrize("rolling", ["A", "C"])
def test_every_kernel_of_a_step_compiles_to_ptx(kernels, rolling):
    backend, k, cuda = kernels
    sim = Simulation([_world(0.0), _world(0.01)], backend="cpu", rolling_friction=rolling)
    arrays = dict(sim.arrays)
    arrays["halt"] = np.zeros(1, dtype=np.int32)
    backend.device_layout(arrays, sim.n_spheres)
    st = pack(arrays, sim.params())
    plan = backend.launch_plan(st, arrays["halt"], sim.n_clumps, sim.n_worlds)
    assert {name for name, *_ in plan} == {n for n in dir(k) if n.startswith("k_")}
    for name, _blocks, _threads, args in plan:
        sig = tuple(numba.typeof(a) for a in args)
        ptx, _ = cuda.compile_ptx(getattr(k, name).py_func, sig, cc=(9, 0))
        assert ".entry" in ptx, name


def test_no_container_field_is_named_like_a_tuple_method():
    """numba-cuda types ``container.index`` as ``tuple.index``: such a field breaks the GPU."""
    tuple_attrs = set(dir(tuple))
    for cls in [*KEYS, Neighbors, Params, EngineState]:
        clash = tuple_attrs.intersection(cls._fields)
        assert not clash, f"{cls.__name__} has fields named like tuple methods: {clash}"
