"""Brief source positions for this plugin's Taichi kernels: a second off every process's start.

Taichi 1.7 turns each kernel's Python code into its IR in every process, before it can look the kernel up in its
offline cache, and on the way it formats a message for every statement and expression: the file, the line, the
source line and a line of carets under the node (``ASTTransformerContext.get_pos_info``; Taichi keeps it as the
node's debug information, for error messages). For the simulator's four CPU sensor kernels those are tens of
thousands of messages, each word-wrapped by ``textwrap``: on the 2-core development CPU README command 1's warm
"compiling kernels" stage (Taichi's front end, then its LLVM IR loaded from the cache) took 2.8-3.1 s with them and
1.9-2.0 s with brief ones (``uv run python benchmarks/first_run.py --warm 3``, with and without
``BENCHBOT_TAICHI_FULL_POSITIONS=1``). The message is not part of the offline cache's key, so kernels already cached
stay cached.

:func:`use_brief_positions` makes the positions brief while a kernel defined in this package compiles (in the
functions it calls too, Taichi's own among them): ``File "...", line N, in function:`` (what Taichi writes first
anyway), without the source excerpt. A compile error in one of these kernels still names its file, line and
function. Kernels defined elsewhere (a user's own, in the same process) keep Taichi's full messages.
``BENCHBOT_TAICHI_FULL_POSITIONS=1`` keeps them for this package's kernels too (when changing them).
"""

from __future__ import annotations

import os
from pathlib import Path

from benchbot.core import settings
from benchbot_sim_taichi.settings import TAICHI_FULL_POSITIONS

#: This package's folder: kernels whose file is under it get brief positions.
PACKAGE_DIR = str(Path(__file__).resolve().parents[1]) + os.sep
_installed = False


def brief_position(file: str, line: int, function: str) -> str:
    """The position Taichi's front end records for a node of a kernel of this package: ``File "<file>", line
    <line>, in <function>:`` and a newline (the first line of Taichi's own message)."""
    return f'File "{file}", line {line}, in {function}:\n'


def use_brief_positions() -> bool:
    """Make Taichi's front end record :func:`brief_position` for the nodes of kernels defined in this package (once
    per process; idempotent). Returns whether brief positions are in use: False when
    ``BENCHBOT_TAICHI_FULL_POSITIONS`` is set to ``1``, or when this Taichi lacks the method this replaces
    (``taichi.lang.ast.ast_transformer_utils.ASTTransformerContext.get_pos_info``, Taichi 1.7): then nothing is
    changed."""
    global _installed
    if _installed:
        return True
    if (settings.get(TAICHI_FULL_POSITIONS) or "") == "1":
        return False
    try:
        from taichi.lang.ast.ast_transformer_utils import ASTTransformerContext
    except ImportError:
        return False
    full = getattr(ASTTransformerContext, "get_pos_info", None)
    if full is None:
        return False

    from taichi.lang import impl

    def ours() -> bool:  # the kernel being compiled is defined in this package (Taichi's own functions it calls too)
        kernel = getattr(impl.get_runtime(), "current_kernel", None)
        code = getattr(getattr(kernel, "func", None), "__code__", None)
        return code is not None and str(code.co_filename).startswith(PACKAGE_DIR)

    def get_pos_info(ctx, node) -> str:
        if not ours():
            return full(ctx, node)
        return brief_position(ctx.file, node.lineno + ctx.lineno_offset, ctx.func.func.__name__)

    get_pos_info.__doc__ = full.__doc__
    ASTTransformerContext.get_pos_info = get_pos_info
    _installed = True
    return True
