"""The tensor arithmetic of reynoldsflow._torch_core stays exact by
construction: a lint over its syntax tree that fails on every operation
that may round differently on another device or reorder (GPU.md's traps).

- division: no ``/`` or ``//`` at all, and ``torch.div`` only inside
  ``_divide``, whose divisor is a full tensor on the dividend's device
  (CUDA divides by a CPU scalar as ``a * (1 / b)``; ``scalar / tensor`` is
  ``reciprocal() * scalar``);
- no Python float operand in arithmetic (constants are ``float32`` tensors
  on the device, ``_f32``), no ``**``;
- no convolution or matrix product (TF32, reordered sums), no fused or
  reordering forms (``addcmul``, ``lerp``, ``alpha=``, ``addmm``, ...),
  no ``float32`` sum reductions (``sum``, ``mean``, ``cumsum``, ...);
- no ``torch.compile``/``jit``/``nn``.
"""

import ast
from pathlib import Path

import reynoldsflow

MODULE = Path(reynoldsflow.__file__).parent / "_torch_core.py"

BANNED_CALLS = {
    # Division and its relatives, outside _divide.
    "div", "divide", "true_divide", "floor_divide", "reciprocal", "rsqrt", "remainder", "fmod",
    # Convolutions and matrix products.
    "conv1d", "conv2d", "conv3d", "conv_transpose1d", "conv_transpose2d", "conv_transpose3d",
    "convolution", "unfold", "fold", "matmul", "mm", "bmm", "mv", "einsum", "dot", "vdot", "inner",
    "outer", "tensordot", "linear", "bilinear", "chain_matmul", "kron",
    # Fused or reordering forms.
    "addcmul", "addcdiv", "lerp", "addmm", "addmv", "addbmm", "baddbmm", "addr", "fma",
    # Sums and other reductions that reorder float additions.
    "sum", "nansum", "mean", "nanmean", "cumsum", "cumprod", "prod", "std", "var", "norm",
    "logsumexp", "trapz", "trapezoid", "avg_pool2d", "interpolate",
    # Library functions that are not one correctly rounded operation.
    "hypot", "pow", "float_power", "exp", "log", "sin", "cos", "round",
    # Compilers.
    "compile", "script", "trace",
}
BANNED_KEYWORDS = {"alpha", "value", "rounding_mode", "out"}
BANNED_OPERATORS = (ast.Div, ast.FloorDiv, ast.MatMult, ast.Pow, ast.Mod)
DIVIDING_FUNCTION = "_divide"


def violations(source: str) -> list:
    """What the lint finds in ``source``: ``(line, reason)`` pairs."""
    found = []
    tree = ast.parse(source)
    # Which function each node is in, for the one place that may divide.
    inside = {}
    for fn in ast.walk(tree):
        if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for node in ast.walk(fn):
                inside.setdefault(node, fn.name)
    for node in ast.walk(tree):
        if isinstance(node, (ast.BinOp, ast.AugAssign)) and isinstance(node.op, BANNED_OPERATORS):
            found.append((node.lineno, f"operator {type(node.op).__name__}"))
        if isinstance(node, ast.BinOp):
            for side in (node.left, node.right):
                if isinstance(side, ast.Constant) and isinstance(side.value, float):
                    found.append((node.lineno, f"Python float {side.value!r} in arithmetic"))
        if isinstance(node, ast.Call):
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else None
            if name in BANNED_CALLS or (name or "").startswith("conv"):
                if not (name == "div" and inside.get(node) == DIVIDING_FUNCTION):
                    found.append((node.lineno, f"call {name}"))
            for kw in node.keywords:
                if kw.arg in BANNED_KEYWORDS:
                    found.append((node.lineno, f"keyword {kw.arg}="))
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            names = [getattr(node, "module", None) or ""] + [a.name for a in node.names]
            if any(n.startswith(("torch.nn", "torch._inductor", "torch.jit", "torch.compile")) or n == "nn"
                   for n in names):
                found.append((node.lineno, f"import {names}"))
        if isinstance(node, ast.Attribute) and node.attr in ("nn", "backends", "jit", "_dynamo"):
            found.append((node.lineno, f"torch.{node.attr}"))
    return found


def test_the_module_uses_only_exact_operations():
    source = MODULE.read_text()
    assert violations(source) == []
    # The one division is there, in _divide.
    assert "torch.div(a, b)" in source


PLANTED = [
    "y = x / det",
    "y = 255.0 / x",
    "y = x // 2",
    "y = torch.div(x, 3)",
    "y = x.div(det)",
    "y = torch.true_divide(x, det)",
    "y = x.reciprocal() * 2",
    "y = x * 0.5",
    "y = 0.5 + x",
    "x /= det",
    "y = x ** 2",
    "y = torch.nn.functional.conv2d(x, k)",
    "y = torch.conv2d(x, k)",
    "y = x @ k",
    "y = torch.matmul(x, k)",
    "y = torch.einsum('ij,jk', x, k)",
    "y = torch.addcmul(x, a, b)",
    "y = torch.lerp(x, a, 0.5)",
    "y = torch.add(x, a, alpha=4)",
    "y = x.sub(a, alpha=2)",
    "y = x.sum(dim=1)",
    "y = torch.sum(x)",
    "y = x.mean()",
    "y = torch.cumsum(x, 0)",
    "y = torch.hypot(x, a)",
    "f = torch.compile(g)",
    "import torch.nn.functional as F",
]


def test_the_lint_fails_on_every_planted_operation():
    base = MODULE.read_text()
    for line in PLANTED:
        planted = base + "\n\ndef _planted(x, a, b, det, k, g):\n    " + line + "\n"
        assert violations(planted), f"the lint missed: {line}"
