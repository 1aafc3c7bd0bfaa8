"""The Python example of docs/discrepancy.md on the findings a fit can return: its loop over ``model.findings_``
called ``f.spec()`` on every finding and crashed with a ParameterError on one dropped for an estimate outside its
effect's valid range (the first 12 s of the Kufieta TEST run give such a torque_constant.scale of 2.53)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ur5fault.discrepancy.candidates import LibraryCandidate
from ur5fault.discrepancy.judging import Finding
from ur5fault.errors import ParameterError

from conftest import REPO


def _documented_loop() -> str:
    """The ``for f in model.findings_:`` loop of the doc's Python example, as written there."""
    text = (REPO / "docs" / "discrepancy.md").read_text()
    lines = text.split("```python\n", 1)[1].split("```", 1)[0].splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("for f in model.findings_"))
    end = next(i for i in range(start + 1, len(lines)) if lines[i] and not lines[i].startswith(" "))
    return "\n".join(lines[start:end])


def _findings() -> list[Finding]:
    kept = Finding(LibraryCandidate("current_sensor_offset", 3, param="offset_A", x0=0.0, probe=0.1),
                   np.array([0.1]), np.array([0.01]), None)
    out_of_range = Finding(LibraryCandidate("torque_constant", 1, param="scale", x0=1.0, probe=0.8),
                           np.array([1.526]), np.array([0.1]), None, kept=False,
                           reason="explains nothing the others do not (estimate outside the effect's valid range)")
    return [kept, out_of_range]


def test_the_documented_loop_runs_on_a_finding_dropped_out_of_range(capsys):
    exec(_documented_loop(), {"model": SimpleNamespace(findings_=_findings())})  # noqa: S102 - the doc's own code
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 2 and out[0].startswith("EffectSpec(name='current_sensor_offset'")
    assert out[1].startswith("dropped shoulder_lift_joint: torque_constant.scale {'scale': 2.526")
    assert out[1].endswith("(estimate outside the effect's valid range)")


def test_a_finding_out_of_its_range_is_no_effect_spec_and_says_why():
    kept, dropped = _findings()
    assert kept.spec().name == "current_sensor_offset" and kept.label == "wrist_1_joint: current_sensor_offset.offset_A"
    assert dropped.values == {"scale": pytest.approx(2.526)}
    with pytest.raises(ParameterError, match=r"^shoulder_lift_joint: torque_constant.scale: fitted torque_constant"
                                             r".scale = 2.526 is outside its valid range \[0.2, 2\], so it is no "
                                             r"effect of a model \(dropped: explains nothing"):
        dropped.spec()


def test_a_payload_finding_says_the_stated_payload_is_contradicted():
    """A run stated at 3 kg that carried none: discrepancy listed 'mass gripped during the pick-and-place - mass_kg
    1.849 kg' among the effects found and never said that the stated 3 kg was what the log contradicted."""
    from ur5fault.discrepancy.report import sentence

    c = LibraryCandidate("payload", None, param="mass_kg", x0=3.0, probe=3.5)
    v0, v1 = c.value(np.array([0.0])), c.value(np.array([1.0]))
    theta = np.array([(1.849 - v0) / (v1 - v0)])  # the coefficient at which it reads 1.849 kg
    f = Finding(c, theta, np.array([0.05]), SimpleNamespace(z=40.0, delta_bic=-300.0))
    text = sentence(f)
    assert "mass_kg 1.849 kg" in text and "where 3 kg was stated: check the payload given (--payload-kg" in text, text
    # model.yaml leaves the job's payload out (a 0 kg robot's tool found this way did not reach monitor's baseline)
    assert "model.yaml does not hold it (a payload is the job's): with model.yaml on this job's logs state " \
           "--payload-kg 1.85" in text, text
    assert "centre of mass" not in text, text
    # stated at 0 kg: the library's centre-of-mass candidates moved nothing (no mass to move), so the finding sits at
    # the stated tool point; omitting the payload fits both (on the nine Kufieta runs wrist_2 0.88 -> 0.64 x UR's
    # model held out, docs/validation.md)
    c0 = LibraryCandidate("payload", None, param="mass_kg", x0=0.0, probe=0.5)
    f0 = Finding(c0, np.array([(1.6 - c0.value(np.array([0.0]))) / (c0.value(np.array([1.0])) - c0.value(
        np.array([0.0])))]), np.array([0.05]), SimpleNamespace(z=40.0, delta_bic=-300.0))
    text = sentence(f0)
    assert ("where 0 kg was stated: check the payload given (--payload-kg, a manifest's payload_kg), or omit it to "
            "have it fitted with its centre of mass (omit --tcp-offset-m too)") in text, text
