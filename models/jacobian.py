"""The Jacobian of a model's first-order system as a numba-compiled function, for callers that need it from
compiled code (CVODE's Jacobian callback, ``integrators.methods.cvode``).

The derivatives are the ones ``Model.jacobian_into`` compiles with heyoka: heyoka differentiates the model's
own expressions (``Model.heyoka_system``, built from the one force source) symbolically (``heyoka.diff``).
Here they go through sympy (``heyoka.to_sympy``), common subexpressions are shared (``sympy.cse``, Meurer et
al., "SymPy: symbolic computing in Python", PeerJ Comput. Sci. 3, e103 (2017), §2.9), and the result is written
out as Python source over the ``math`` module and compiled with ``models.jit.jit``. Floating-point constants
are printed with ``repr`` (shortest round-tripping decimal), so the compiled function uses the same doubles as
the expressions. The sympy rewriting may reorder operations, so the values agree with ``Model.jacobian_into``
to round-off, not bitwise.
"""

from __future__ import annotations

from typing import Callable, Sequence

from foucault_bench.models.jit import jit

STATE_ARRAY = "state"
PARAMETER_ARRAY = "p"
OUTPUT_ARRAY = "out"


def jacobian_source(system: Sequence, function_name: str = "jacobian_into") -> str:
    """Python source of ``function_name(t, state, out, p)`` writing ∂(dy/dt)_i/∂y_j into ``out[i, j]`` (all 16
    entries, zeros included) for the first-order ``system``, heyoka (variable, expression) pairs as
    ``Model.heyoka_system`` returns them; ``p`` is the full parameter vector. Takes the system, not the model:
    this module sits below ``models.base``, which imports it."""
    import heyoka
    import sympy
    from sympy.printing.pycode import PythonCodePrinter

    variables = [variable for variable, _ in system]
    derivatives = [heyoka.to_sympy(heyoka.diff(rhs, variable)) for _, rhs in system for variable in variables]
    state_index = {str(variable): index for index, variable in enumerate(variables)}
    renamed = {}
    for symbol in set().union(*(sympy.sympify(expression).free_symbols for expression in derivatives)):
        if symbol.name in state_index:
            renamed[symbol] = sympy.Symbol(f"s_{state_index[symbol.name]}")
        elif symbol.name.startswith("par[") and symbol.name.endswith("]"):
            renamed[symbol] = sympy.Symbol(f"p_{int(symbol.name[4:-1])}")
        else:
            raise ValueError(f"{function_name}: unexpected symbol {symbol.name!r} in the Jacobian")
    derivatives = [sympy.sympify(expression).xreplace(renamed) for expression in derivatives]
    shared, reduced = sympy.cse(derivatives, symbols=sympy.numbered_symbols("c_"))

    class Printer(PythonCodePrinter):
        def _print_Float(self, expr):  # sympy's printer protocol names the method
            return repr(float(expr))

    printer = Printer({"standard": "python3"})
    lines = [f"def {function_name}(t, {STATE_ARRAY}, {OUTPUT_ARRAY}, {PARAMETER_ARRAY}):"]
    lines += [f"    s_{index} = {STATE_ARRAY}[{index}]" for index in range(len(variables))]
    used = sorted({int(symbol.name[2:]) for symbol in renamed.values() if symbol.name.startswith("p_")})
    lines += [f"    p_{index} = {PARAMETER_ARRAY}[{index}]" for index in used]
    lines += [f"    {symbol} = {printer.doprint(expression)}" for symbol, expression in shared]
    size = len(variables)
    lines += [f"    {OUTPUT_ARRAY}[{k // size}, {k % size}] = {printer.doprint(expression)}"
              for k, expression in enumerate(reduced)]
    return "\n".join(lines) + "\n"


def numba_jacobian_into(system: Sequence, model_name: str) -> Callable:
    """njit ``(t, state, out, p) -> None`` writing the Jacobian of the first-order ``system`` of the model
    ``model_name`` into the (4, 4) array ``out`` (row i = component of dy/dt, column j = state variable; any
    memory layout)."""
    import math

    function_name = f"jacobian_into_{model_name}"
    source = jacobian_source(system, function_name)
    namespace: dict = {"math": math, "__name__": __name__}
    exec(compile(source, __file__, "exec"), namespace)  # this file's name: numba's disk cache needs a real file
    return jit(namespace[function_name])
