"""Rendering the gate's outcomes: a table (plain text or Markdown), one line per failure, JUnit XML."""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ElementTree
from typing import Sequence

from foucault_bench.bench.gate.evaluate import Outcome


def _format_number(value: float | str | None) -> str:
    if value is None:
        return "–"
    if isinstance(value, str):
        return value
    if not math.isfinite(value):
        return "nan"
    return str(int(value)) if value.is_integer() and abs(value) < 1e9 else f"{value:.3g}"


def _format_margin(outcome: Outcome) -> str:
    if outcome.margin is None:
        return "–"
    return f"x{outcome.margin:.3g}" if outcome.margin_is_factor else f"{outcome.margin:+.3g}"


def render(outcomes: Sequence[Outcome], *, markdown: bool) -> str:
    """The table of every checked line, a summary line, and one line per failure with its basis."""
    from tabulate import tabulate

    header = ["#", "scene", "integrator", "setting", "bound", "measured", "margin", "result"]
    lines = [[outcome.bound.number, outcome.scene, outcome.integrator, outcome.setting, outcome.bound.label,
              _format_number(outcome.measured), _format_margin(outcome), "pass" if outcome.passed else "FAIL"]
             for outcome in outcomes]
    table = tabulate(lines, headers=header, tablefmt="github" if markdown else "simple", disable_numparse=True)
    failures = [outcome for outcome in outcomes if not outcome.passed]
    bounds = len({outcome.bound.number for outcome in outcomes})
    summary = (f"{bounds} bounds, {len(outcomes)} checks: {len(outcomes) - len(failures)} passed, "
               f"{len(failures)} failed")
    text = [table, "", f"**{summary}**" if markdown else summary]
    if failures:
        text += ["", "Failed:" if not markdown else "Failed bounds:"]
        text += [("- " if markdown else "  ") + failure_line(outcome) for outcome in failures]
    return "\n".join(text)


def failure_line(outcome: Outcome) -> str:
    """One failed check in words: where, what, how much, and why the bound is what it is."""
    parts = [f"bound #{outcome.bound.number} {outcome.scene} {outcome.integrator} {outcome.setting}: "
             f"{outcome.bound.label} violated, measured {_format_number(outcome.measured)}"]
    if outcome.detail:
        parts.append(f"({outcome.detail})")
    if outcome.bound.basis:
        parts.append(f"[basis: {outcome.bound.basis}]")
    return " ".join(parts)


def junit_xml(outcomes: Sequence[Outcome], *, suite: str) -> ElementTree.ElementTree:
    """JUnit XML (the de-facto schema read by CI systems: testsuites/testsuite/testcase/failure), one test case
    per checked line."""
    failures = sum(not outcome.passed for outcome in outcomes)
    suites = ElementTree.Element("testsuites", name="foucault-bench check", tests=str(len(outcomes)),
                                 failures=str(failures), errors="0")
    testsuite = ElementTree.SubElement(suites, "testsuite", name=suite, tests=str(len(outcomes)),
                                       failures=str(failures), errors="0", skipped="0")
    for outcome in outcomes:
        case = ElementTree.SubElement(
            testsuite, "testcase", classname=f"check.{outcome.scene}.{outcome.integrator}",
            name=f"#{outcome.bound.number} {outcome.setting} {outcome.bound.label}")
        measured = (f"measured {_format_number(outcome.measured)}, bound {outcome.bound.label}, "
                    f"margin {_format_margin(outcome)}")
        if not outcome.passed:
            failure = ElementTree.SubElement(case, "failure", message=failure_line(outcome), type="BoundViolated")
            failure.text = measured
        ElementTree.SubElement(case, "system-out").text = "; ".join(
            filter(None, [measured, outcome.detail, outcome.bound.basis and f"basis: {outcome.bound.basis}"]))
    for element in suites.iter():  # texts from the user's files and database, made writable as XML 1.0
        element.text = element.text and _xml_characters(element.text)
        element.attrib = {key: _xml_characters(value) for key, value in element.attrib.items()}
    ElementTree.indent(suites)
    return ElementTree.ElementTree(suites)


_NOT_IN_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff\ud800-\udfff]")
"""Characters XML 1.0 cannot hold, escaped or not (w3.org/TR/xml, production [2] Char)."""


def _xml_characters(text: str) -> str:
    """``text`` with each character XML cannot hold written as its Python escape (``\\x01``): an XML parser
    refuses the whole file for one of them."""
    return _NOT_IN_XML.sub(lambda match: match.group().encode("unicode_escape").decode("ascii"), text)
