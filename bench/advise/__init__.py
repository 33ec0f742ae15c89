"""``foucault-bench advise``: for one scene and one target error, the cheapest integrator and setting, measured.

The answer comes from the results store: among the stored runs of the scene (every matrix run; the rows of the
scene's physics, ``bench.problems.scene_key``, whatever name they were stored under, so that a name reused with
other physics is never mixed in; the latest row of each integrator and setting), the cheapest ok run whose error
meets the target (``bench.verdicts.pareto``; cost = CPU time where stored, else wall time), its measured cost,
the next two (the cheapest runs of two other integrators meeting it), and which model the scene needs at that
accuracy (from the model-adequacy rows the runner stores for the scene's physics: what a simpler model gets
wrong, or what the scene's model leaves out, compared with the target). Its cost counts are RHS evaluations, or
Taylor steps for the taylor family.

When no stored run meets the target, a small targeted search runs and stores its runs like any matrix run
(``bench.advise.search``). The modules: ``target`` (what is asked, and its problems), ``ranking`` (the stored
runs and the cheapest meeting the target), ``model`` (the model the scene needs), ``search``, ``answer``
(``advise``: all of it as one ``Advice``) and ``render`` (text and JSON).
"""

from foucault_bench.bench.advise.answer import Advice, advise
from foucault_bench.bench.advise.render import render_json, render_text
from foucault_bench.bench.advise.target import Target, metric_problem, parse_target, resolve_scene

__all__ = ["Advice", "Target", "advise", "metric_problem", "parse_target", "render_json", "render_text",
           "resolve_scene"]
