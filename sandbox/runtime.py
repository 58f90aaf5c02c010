"""The one place that calls ``ti.init``.

Kernels are arch-agnostic: the same code runs on ``cpu`` (default) or ``gpu``/``cuda``/
``vulkan`` when a device exists. ``float64`` switches Taichi's default float type; it is
the default (:data:`DEFAULT_FLOAT64`), ``float64=False`` gives float32.
"""

from __future__ import annotations

import logging

import taichi as ti

from sandbox.errors import SandboxError
from sandbox.precision import DEFAULT_FLOAT64

log = logging.getLogger(__name__)

_ARCHES = {"cpu": "cpu", "gpu": "gpu", "cuda": "cuda", "vulkan": "vulkan", "metal": "metal"}
_state: dict = {"initialised": False, "arch": None, "float64": None, "debug": False}

MAX_SNODE_TREES = 512
"""Taichi's limit on field trees per runtime (LLVM backends). Every field allocated and
then written before the next one is allocated becomes a tree of its own, and trees are
never freed while the runtime lives: a process that builds many scenes (the report, the
test suite) ran out and crashed inside Taichi (a segmentation fault, no message)."""
RECYCLE_AT = 160


def init(arch: str = "cpu", *, float64: bool = DEFAULT_FLOAT64, debug: bool = False,
         profile: bool = False) -> None:  # fmt: skip
    """Initialise Taichi once per process.

    Calling again with the same settings is a no-op; with other settings Taichi is reset
    (all fields and models made before become invalid). ``profile`` turns on Taichi's
    kernel profiler (per-loop times, ``ti.profiler.print_kernel_profiler_info``; for
    benchmarks, it slows every launch down a little).

    Taichi's own IR optimisation passes are off (``advanced_optimization=False``); LLVM
    still optimises every kernel. Measured on the t-shirt's first drape at 1 cm (this
    2-core CPU, no kernels cached): compilation 18.8 -> 7.4 s, the kernels' own run time
    unchanged (13.3 -> 11.7 s), and `benchmarks/bench_step.py` within noise either way.
    """
    if arch not in _ARCHES:
        raise SandboxError(f"unknown arch {arch!r}: choose one of {', '.join(_ARCHES)}")
    if _state["initialised"] and _state["arch"] == arch and _state["float64"] == float64:
        return
    if _state["initialised"]:
        ti.reset()
    _short_source_positions()
    _parse_sources_once()
    ti.init(
        arch=getattr(ti, _ARCHES[arch]),
        default_fp=ti.f64 if float64 else ti.f32,
        debug=debug,
        offline_cache=True,
        advanced_optimization=False,
        log_level=ti.WARN,
        kernel_profiler=profile,
    )
    _state.update(initialised=True, arch=arch, float64=float64, debug=debug)
    log.debug("taichi initialised on %s (float64=%s)", arch, float64)


def _short_source_positions() -> None:
    """Make Taichi's compiler record a kernel line's position without formatting it.

    Taichi's front end formats, for every statement and expression it compiles, the message
    it would print if that node failed: the file and line, then the source wrapped at 80
    columns with a caret line under the node. That formatting was 40 % of the front end's
    time (4.1 of 9.7 s on the t-shirt's coarse-to-fine drape, 85,000 nodes). The short form
    keeps the file, the line, the function and the source line; a compilation error still
    says where it is. Applied once, to Taichi 1.7's ``ASTTransformerContext``; a Taichi
    without that method keeps its own.
    """
    from taichi.lang.ast import ast_transformer_utils as utils

    ctx = getattr(utils, "ASTTransformerContext", None)
    if ctx is None or not hasattr(ctx, "get_pos_info") or getattr(ctx, "_sandbox_short", False):
        return

    def get_pos_info(self, node) -> str:
        src = self.src[node.lineno - 1] if 0 < node.lineno <= len(self.src) else ""
        return (f'File "{self.file}", line {node.lineno + self.lineno_offset}, in '
                f"{self.func.func.__name__}:\n{src}\n")  # fmt: skip

    ctx.get_pos_info = get_pos_info
    ctx._sandbox_short = True


def _parse_sources_once() -> None:
    """Make Taichi's front end read and tidy each kernel's and function's source once.

    Taichi 1.7 reads a function's source from its file (``inspect.getsourcelines``, which
    tokenizes the file), wraps every line and dedents it each time it compiles a kernel and
    each time a kernel inlines a ``ti.func``: thousands of times per drape, for a few dozen
    functions, since every level's kernels are compiled for that level's fields. Here the
    tidied source is kept per function and only parsed again (the parse tree is changed by
    compiling, so it is not shared). Measured on the t-shirt's drape at 1 cm, kernels
    cached: the front end 2.1 -> 1.25 s. Applied once, to Taichi 1.7's
    ``kernel_impl._get_tree_and_ctx``; another Taichi keeps its own.
    """
    import ast
    import inspect
    import textwrap

    from taichi.lang import kernel_impl
    from taichi.lang.ast import ASTTransformerContext

    original = getattr(kernel_impl, "_get_tree_and_ctx", None)
    expected = ["self", "excluded_parameters", "is_kernel", "arg_features", "args",
                "ast_builder", "is_real_function"]  # fmt: skip
    if (original is None or getattr(original, "_sandbox_cached", False)
            or list(inspect.signature(original).parameters) != expected):  # fmt: skip
        return
    sources: dict = {}

    def _get_tree_and_ctx(self, excluded_parameters=(), is_kernel=True, arg_features=None,
                          args=None, ast_builder=None, is_real_function=False):  # fmt: skip
        known = sources.get(self.func)
        if known is None:
            file = kernel_impl.getsourcefile(self.func)
            src, start_lineno = kernel_impl.getsourcelines(self.func)
            src = [textwrap.fill(line, tabsize=4, width=9999) for line in src]
            known = sources[self.func] = (file, src, start_lineno,
                                          textwrap.dedent("\n".join(src)))  # fmt: skip
        file, src, start_lineno, text = known
        tree = ast.parse(text)
        tree.body[0].decorator_list = []
        global_vars = kernel_impl._get_global_vars(self.func)
        if is_kernel or is_real_function:  # template parameters become globals
            for i in self.template_slot_locations:
                global_vars[self.arguments[i].name] = args[i]
        return tree, ASTTransformerContext(
            excluded_parameters=excluded_parameters, is_kernel=is_kernel, func=self,
            arg_features=arg_features, global_vars=global_vars, argument_data=args, src=src,
            start_lineno=start_lineno, file=file, ast_builder=ast_builder,
            is_real_function=is_real_function,
        )  # fmt: skip

    _get_tree_and_ctx._sandbox_cached = True
    kernel_impl._get_tree_and_ctx = _get_tree_and_ctx


def ensure_init() -> None:
    """Initialise with defaults (CPU, :data:`DEFAULT_FLOAT64`) if nobody did yet."""
    if not _state["initialised"]:
        init()


def arch() -> str:
    """The arch Taichi was initialised with (``"cpu"`` before initialisation)."""
    return _state["arch"] or "cpu"


def is_initialised() -> bool:
    return bool(_state["initialised"])


def is_float64() -> bool:
    """The precision Taichi runs (or will run, once initialised with defaults) in."""
    if not _state["initialised"]:
        return DEFAULT_FLOAT64
    return bool(_state["float64"])


def float_dtype():
    """The numpy float type matching Taichi's default float."""
    import numpy as np

    return np.float64 if is_float64() else np.float32


def snode_trees() -> int:
    """Field trees allocated in this Taichi runtime so far (0 before initialisation)."""
    if not _state["initialised"]:
        return 0
    from taichi.lang import impl

    return int(impl.get_runtime().prog.get_snode_tree_size())


def recycle(threshold: int = RECYCLE_AT) -> bool:
    """Start a fresh Taichi runtime (same arch and precision) if more than ``threshold``
    field trees are allocated; returns True if it did.

    Call it between independent scenes only: every field, model, state and solver made
    before becomes invalid. Kernels are compiled again on first use (the offline cache
    makes that quick).
    """
    if snode_trees() <= threshold:
        return False
    ti.reset()
    _state["initialised"] = False
    init(_state["arch"] or "cpu", float64=bool(_state["float64"]), debug=bool(_state["debug"]))
    log.debug("taichi runtime recycled after %d field trees", threshold)
    return True
