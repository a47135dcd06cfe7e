"""A model with findings' changes applied: what ``update`` writes, and what ``diagnose``'s
second pass searches against when the model was wrong from the record's start."""
from __future__ import annotations

from .result import ModelChange


def apply_changes(model, changes: list[ModelChange], name: str | None = None):
    """A new mpmpp.Model: ``model`` with the channel, noise and valve changes applied (a later
    change of the same channel replaces an earlier one)."""
    from ..io import Model

    process = {o: dict(chans) for o, chans in model.process_dict().items()}
    noise = dict(model.noise_dict())
    actuators = dict(model.actuators_dict())
    inputs = list(model.inputs)
    for c in changes:
        if c.actuator is not None:
            actuators[c.input] = c.actuator
        if c.channel is not None:
            if c.new_input and c.input not in inputs:
                inputs.append(c.input)
            process.setdefault(c.output, {})[c.input] = c.channel
        if c.noise is not None:
            noise[c.output] = c.noise
    return Model(name or f"{model.name} (updated)", model.sample_time_s, inputs, list(model.outputs),
                 process, noise, actuators)
