"""update with a finding that changes several outputs (an actuator nonlinearity of an input
driving several outputs gives every channel of that input a new gain): every changed output
gets its error line, each from the finding's onset."""
import sys

import numpy as np

import mpmpp
from mpmpp.diagnose import ModelChange, diagnose
from mpmpp.update import update

from example_cases import MISSING_COUPLING, load_case


def test_a_finding_changing_two_outputs_gets_two_error_lines(monkeypatch):
    model, data, _ = load_case(MISSING_COUPLING)
    diagnosis = diagnose(model, data)
    top = diagnosis.findings[0]
    other = next(o for o in model.outputs if o != top.output)
    column, channel = next(iter(model.process_dict()[other].items()))
    scaled = mpmpp.TransferFunction(np.asarray(channel.num) * 0.9, channel.den, channel.delay)
    top.extra_changes = [ModelChange(output=other, input=column, channel=scaled)]
    monkeypatch.setattr(sys.modules["mpmpp.update"], "diagnose", lambda *args, **kwargs: diagnosis)
    res = update(model, data, top.id)
    assert [e.output for e in res.errors] == [top.output, other]
    assert all(e.onset_s == top.onset_s for e in res.errors)
    assert all(np.isfinite(e.error_before) and np.isfinite(e.error_after) for e in res.errors)
    assert np.allclose(res.model.process_dict()[other][column].num, scaled.num)
