"""Scenario files: a model file (docs/formats.md) extended with the truth, the controller,
the duration and scheduled events (docs/scenario.md).

``parse_scenario(dict)`` validates and returns a :class:`Scenario`; every error is one
``ValueError`` line naming the field (``events[2].factor: must be a number``).
``Scenario.to_config(seed)`` builds the engine's ``ClosedLoopConfig``.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import _core
from ._core import LARGEST_VALUE

MODEL_KEYS = {"name", "sample_time_s", "inputs", "outputs", "process", "noise", "actuators"}
MAX_SAMPLES = 100_000_000  # ~16 years at 5 s
TOP_KEYS = MODEL_KEYS | {"truth", "controller", "duration_s", "seed", "events", "notes"}
TRUTH_KEYS = {"process", "noise", "sigma", "extra", "actuators", "outliers"}
OUTLIER_KEYS = {"probability", "size"}
EXTRA_KEYS = {"operating_point", "sigma", "noise", "affects"}
ACTUATOR_KEYS = {"stiction_s", "stiction_j", "deadband", "backlash", "min", "max"}
CONTROLLER_KEYS = {"kind", "prediction_horizon", "control_horizon", "cv", "mv", "disturbance", "clip_moves"}
PID_KEYS = {"kind", "cv", "mv", "loops"}
PID_LOOP_KEYS = {"cv", "mv", "gain", "integral_time_s", "derivative_time_s", "derivative_filter", "min", "max"}
CV_KEYS = {"target", "target_weight", "minmax_weight", "min", "max", "max_move", "scale"}
MV_KEYS = {"target", "target_weight", "move_weight", "deviation_weight", "minmax_weight",
           "min", "max", "max_move", "soft_min", "soft_max", "scale"}
# event type -> (required keys, optional keys), besides "time_s" and "type"
EVENT_KEYS = {
    "process": ({"output", "input", "model"}, {"switch"}),
    "gain": ({"output", "input", "factor"}, {"switch"}),
    "time_constant": ({"output", "input", "factor"}, {"switch"}),
    "delay": ({"output", "input", "delay"}, {"switch"}),
    "noise": ({"output", "model"}, set()),
    "sigma": ({"output", "value"}, set()),
    "drift": ({"output"}, {"offset", "rate_per_s"}),
    "actuator": ({"input"}, ACTUATOR_KEYS),
    "setpoint": ({"output", "value"}, set()),
    "mv_target": ({"input", "value"}, set()),
    "extra_channel": ({"output", "extra", "model"}, set()),
}
INF = math.inf
# How a channel event switches the truth (cpp/include/mpmpp/closed_loop.hpp): "replay" the new
# channel as if it had always been there (no transient), or "fresh" from rest on the inputs from
# the event on while the old channel's response to the earlier inputs fades out.
CHANNEL_SWITCHES = ("replay", "fresh")
CHANNEL_EVENTS = ("process", "gain", "time_constant", "delay")   # the event types that take "switch"


def _fail(where: str, msg: str):
    raise ValueError(f"{where}: {msg}")


def _obj(value, where: str, allowed: set[str] | None = None, required: set[str] = frozenset()) -> dict:
    if not isinstance(value, dict):
        _fail(where or "scenario", "must be an object")
    if allowed is not None:
        for key in value:
            if key not in allowed:
                _fail(f"{where}.{key}" if where else key, f"unknown key (allowed: {', '.join(sorted(allowed))})")
    for key in required:
        if key not in value:
            _fail(f"{where}.{key}" if where else key, "is required")
    return value


def _num(value, where: str, *, minimum: float | None = None, positive: bool = False,
         allow_inf: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        _fail(where, "must be a number")
    x = float(value)
    if math.isnan(x) or (math.isinf(x) and not allow_inf):
        _fail(where, "must be finite")
    if math.isfinite(x) and abs(x) >= LARGEST_VALUE:   # the data file it writes could not be read
        _fail(where, f"too large to compute with, got {x:g} (magnitude {LARGEST_VALUE:g} or more)")
    if positive and not x > 0:
        _fail(where, "must be > 0")
    if minimum is not None and x < minimum:
        _fail(where, f"must be >= {minimum:g}")
    return x


def _int(value, where: str, minimum: int = 0) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or float(value) != int(value):
        _fail(where, "must be an integer")
    if int(value) < minimum:
        _fail(where, f"must be >= {minimum}")
    if int(value) >= 2**63:  # seeds are uint64, sample counts int: no silent wrap-around
        _fail(where, "must be < 2^63")
    return int(value)


def _limit(value, where: str, default: float) -> float:
    """A limit: a number, or null / absent for none."""
    return default if value is None else _num(value, where)


def parse_transfer_function(value, where: str, sample_time_s: float) -> _core.TransferFunction:
    """A channel in the model file's discrete or first-order-plus-dead-time form, read by the
    model-file reader itself (so both accept exactly the same channels)."""
    doc = {"sample_time_s": sample_time_s, "inputs": ["u"], "outputs": ["y"], "process": {"y": {"u": value}}}
    try:
        return _core.Model.from_json(json.dumps(doc), "").process("y", "u")
    except ValueError as exc:
        detail = str(exc).split("process.y.u", 1)[-1].lstrip(".: ")
        raise ValueError(f"{where}: {detail}") from None


def _model(spec: dict, where: str, process, noise, actuators=None) -> _core.Model:
    """A Model through the model-file reader; `where` prefixes its error paths."""
    doc = {k: spec[k] for k in ("name", "sample_time_s", "inputs", "outputs") if k in spec}
    if actuators is not None:
        doc["actuators"] = actuators
    doc["process"] = process
    if noise is not None:
        doc["noise"] = noise
    try:
        return _core.Model.from_json(json.dumps(doc), "")
    except ValueError as exc:
        detail = str(exc).lstrip(": ")
        raise ValueError(f"{where}{detail}") from None


def _name(value, where, names, kind):
    if value not in names:
        _fail(where, f"unknown {kind} {value!r} (known: {', '.join(names)})")
    return names.index(value)


@dataclass
class Scenario:
    """A validated scenario; ``spec`` is the JSON document it came from."""

    spec: dict
    model: Any          # the nominal Model (what the MPC uses)
    truth: Any          # the true plant at the start, as a Model (process and noise)
    sigma: list[float]
    extra_names: list[str]
    extra: list
    extra_process: list
    actuators: list
    tuning: Any
    pid_loops: list
    outlier_probability: float
    outlier_size: list
    num_samples: int
    seed: int
    events: list = field(default_factory=list)

    @property
    def name(self) -> str:
        return self.model.name

    @property
    def sample_time_s(self) -> float:
        return self.model.sample_time_s

    @property
    def inputs(self) -> list[str]:
        return list(self.model.inputs)

    @property
    def outputs(self) -> list[str]:
        return list(self.model.outputs)

    def to_config(self, seed: int | None = None, record_qps: bool = False) -> _core.ClosedLoopConfig:
        cfg = _core.ClosedLoopConfig()
        cfg.model = self.model
        cfg.tuning = self.tuning
        plant = _core.Plant()
        plant.process = [[self.truth.process(o, i) for i in self.inputs] for o in self.outputs]
        plant.noise = [self.truth.noise(o) for o in self.outputs]
        plant.sigma = np.asarray(self.sigma, float)
        plant.extra = self.extra
        plant.extra_process = self.extra_process
        plant.actuators = self.actuators
        plant.outlier_probability = self.outlier_probability
        plant.outlier_size = np.asarray(self.outlier_size, float)
        cfg.plant = plant
        cfg.pid_loops = self.pid_loops
        cfg.num_samples = self.num_samples
        cfg.seed = self.seed if seed is None else _int(seed, "seed")
        cfg.events = self.events
        cfg.record_qps = record_qps
        return cfg


def _actuator(spec, where) -> _core.ActuatorNonlinearity:
    a = _core.ActuatorNonlinearity()
    a.stiction_s = _num(spec.get("stiction_s", 0.0), f"{where}.stiction_s", minimum=0)
    a.stiction_j = _num(spec.get("stiction_j", 0.0), f"{where}.stiction_j", minimum=0)
    if a.stiction_j > a.stiction_s:
        _fail(f"{where}.stiction_j", "must be <= stiction_s")
    a.deadband = _num(spec.get("deadband", 0.0), f"{where}.deadband", minimum=0)
    a.backlash = _num(spec.get("backlash", 0.0), f"{where}.backlash", minimum=0)
    a.min = _limit(spec.get("min"), f"{where}.min", -INF)
    a.max = _limit(spec.get("max"), f"{where}.max", INF)
    if a.min > a.max:
        _fail(f"{where}.min", "must be <= max")
    return a


def _tuning(spec, outputs, inputs) -> Any:
    """Controller section -> MpcTuning. Weights in the file apply to scaled variables
    (value / scale, scale default 1): the engine's weights are weight / scale^2. Real MD-MPCs
    carry CV/MV scaling apart from the weights; the paper's tables list only the weights.
    The MV target term is normalised by the MV's range inside the engine (mpc.hpp), so the
    MV scale does not apply to it."""
    c = _obj(spec, "controller", CONTROLLER_KEYS, {"prediction_horizon", "control_horizon", "cv", "mv"})
    t = _core.MpcTuning()
    t.prediction_horizon = _int(c["prediction_horizon"], "controller.prediction_horizon", 1)
    t.control_horizon = _int(c["control_horizon"], "controller.control_horizon", 1)
    if t.control_horizon > t.prediction_horizon:
        _fail("controller.control_horizon", "must be <= prediction_horizon")
    disturbance = c.get("disturbance", "bias")
    if disturbance not in ("bias", "noise_model"):
        _fail("controller.disturbance", f"must be 'bias' or 'noise_model', got {disturbance!r}")
    t.disturbance = getattr(_core.DisturbanceModel, disturbance)
    clip = c.get("clip_moves", False)
    if not isinstance(clip, bool):
        _fail("controller.clip_moves", f"must be true or false, got {clip!r}")
    t.clip_moves = clip
    cvs = _obj(c["cv"], "controller.cv", set(outputs), set(outputs))
    mvs = _obj(c["mv"], "controller.mv", set(inputs), set(inputs))
    cv = {k: [] for k in ("target", "target_weight", "minmax_weight", "min", "max", "max_move")}
    for name in outputs:
        w = f"controller.cv.{name}"
        s = _obj(cvs[name], w, CV_KEYS, {"target"})
        scale = _num(s.get("scale", 1.0), f"{w}.scale", positive=True)
        cv["target"].append(_num(s["target"], f"{w}.target"))
        cv["target_weight"].append(_num(s.get("target_weight", 1.0), f"{w}.target_weight", minimum=0) / scale**2)
        cv["minmax_weight"].append(_num(s.get("minmax_weight", 1.0), f"{w}.minmax_weight", minimum=0) / scale**2)
        cv["min"].append(_limit(s.get("min"), f"{w}.min", -INF))
        cv["max"].append(_limit(s.get("max"), f"{w}.max", INF))
        mm = s.get("max_move")
        cv["max_move"].append(INF if mm is None else _num(mm, f"{w}.max_move", positive=True))
        if cv["min"][-1] > cv["max"][-1]:
            _fail(f"{w}.min", "must be <= max")
    mv = {k: [] for k in ("target", "target_weight", "move_weight", "deviation_weight", "minmax_weight",
                          "min", "max", "max_move", "soft_min", "soft_max")}
    for name in inputs:
        w = f"controller.mv.{name}"
        s = _obj(mvs[name], w, MV_KEYS, {"target", "move_weight"})
        scale = _num(s.get("scale", 1.0), f"{w}.scale", positive=True)
        mv["target"].append(_num(s["target"], f"{w}.target"))
        mv["target_weight"].append(_num(s.get("target_weight", 0.0), f"{w}.target_weight", minimum=0))
        mv["move_weight"].append(_num(s["move_weight"], f"{w}.move_weight", positive=True) / scale**2)
        mv["deviation_weight"].append(_num(s.get("deviation_weight", 0.0), f"{w}.deviation_weight", minimum=0) / scale**2)
        mv["minmax_weight"].append(_num(s.get("minmax_weight", 1.0), f"{w}.minmax_weight", minimum=0) / scale**2)
        for key, default in (("min", -INF), ("max", INF), ("soft_min", -INF), ("soft_max", INF)):
            mv[key].append(_limit(s.get(key), f"{w}.{key}", default))
        mm = s.get("max_move")
        mv["max_move"].append(INF if mm is None else _num(mm, f"{w}.max_move", positive=True))
        if mv["min"][-1] > mv["max"][-1]:
            _fail(f"{w}.min", "must be <= max")
        if not mv["min"][-1] <= mv["target"][-1] <= mv["max"][-1]:
            _fail(f"{w}.target", "must lie within [min, max] (it is the starting input)")
    t.cv_target = np.array(cv["target"])
    t.cv_target_weight = np.array(cv["target_weight"])
    t.cv_minmax_weight = np.array(cv["minmax_weight"])
    t.cv_min, t.cv_max, t.cv_max_move = (np.array(cv[k]) for k in ("min", "max", "max_move"))
    t.mv_target = np.array(mv["target"])
    t.mv_target_weight = np.array(mv["target_weight"])
    t.move_weight = np.array(mv["move_weight"])
    t.deviation_weight = np.array(mv["deviation_weight"])
    t.mv_minmax_weight = np.array(mv["minmax_weight"])
    t.mv_min, t.mv_max, t.mv_max_move = (np.array(mv[k]) for k in ("min", "max", "max_move"))
    t.mv_soft_min, t.mv_soft_max = np.array(mv["soft_min"]), np.array(mv["soft_max"])
    return t


def _pid(spec, outputs, inputs) -> tuple[Any, list]:
    """Controller section of kind "pid" -> (MpcTuning holding only the start point, loops).
    cv.<name>.target is the initial setpoint, mv.<name>.target the initial input (inputs
    without a loop stay there)."""
    c = _obj(spec, "controller", PID_KEYS, {"cv", "mv", "loops"})
    cvs = _obj(c["cv"], "controller.cv", set(outputs), set(outputs))
    mvs = _obj(c["mv"], "controller.mv", set(inputs), set(inputs))
    t = _core.MpcTuning()
    t.cv_target = np.array([_num(_obj(cvs[o], f"controller.cv.{o}", {"target"}, {"target"})["target"],
                                 f"controller.cv.{o}.target") for o in outputs])
    t.mv_target = np.array([_num(_obj(mvs[i], f"controller.mv.{i}", {"target"}, {"target"})["target"],
                                 f"controller.mv.{i}.target") for i in inputs])
    if not isinstance(c["loops"], list) or not c["loops"]:
        _fail("controller.loops", "must be a non-empty list")
    loops, seen = [], set()
    for k, spec_k in enumerate(c["loops"]):
        w = f"controller.loops[{k}]"
        s = _obj(spec_k, w, PID_LOOP_KEYS, {"cv", "mv", "gain", "integral_time_s"})
        loop = _core.PidLoop()
        loop.output = _name(s["cv"], f"{w}.cv", outputs, "output")
        loop.input = _name(s["mv"], f"{w}.mv", inputs, "input")
        for key, index in (("cv", loop.output), ("mv", loop.input)):
            if (key, index) in seen:
                _fail(f"{w}.{key}", "is already in another loop")
            seen.add((key, index))
        loop.gain = _num(s["gain"], f"{w}.gain")
        if loop.gain == 0:
            _fail(f"{w}.gain", "must be non-zero (its sign is the controller action)")
        ti = s["integral_time_s"]
        loop.integral_time_s = INF if ti is None else _num(ti, f"{w}.integral_time_s", positive=True)
        loop.derivative_time_s = _num(s.get("derivative_time_s", 0.0), f"{w}.derivative_time_s", minimum=0)
        loop.derivative_filter = _num(s.get("derivative_filter", 10.0), f"{w}.derivative_filter", positive=True)
        loop.min = _limit(s.get("min"), f"{w}.min", -INF)
        loop.max = _limit(s.get("max"), f"{w}.max", INF)
        if not loop.min <= t.mv_target[loop.input] <= loop.max:
            _fail(f"{w}.min", f"[min, max] must contain the initial input controller.mv.{s['mv']}.target")
        loops.append(loop)
    return t, loops


def _outliers(spec, outputs) -> tuple[float, list[float]]:
    o = _obj(spec, "truth.outliers", OUTLIER_KEYS, OUTLIER_KEYS)
    p = _num(o["probability"], "truth.outliers.probability", minimum=0)
    if p > 1:
        _fail("truth.outliers.probability", "must be <= 1")
    sizes = _obj(o["size"], "truth.outliers.size", set(outputs), set(outputs))
    return p, [_num(sizes[n], f"truth.outliers.size.{n}", minimum=0) for n in outputs]


def _scale_poles(g: _core.TransferFunction, factor: float, where: str) -> _core.TransferFunction:
    """Time constants x factor at unchanged steady-state gain: each real pole p in (0, 1)
    (p = exp(-Ts/T)) becomes p^(1/factor)."""
    poles = np.asarray(g.poles())
    if np.any(np.abs(poles.imag) > 1e-12) or np.any(poles.real <= 0) or np.any(poles.real >= 1):
        _fail(where, "time_constant events need a channel whose poles are all real in (0, 1)")
    den = np.real(np.poly(poles.real ** (1.0 / factor))) if len(poles) else np.array([1.0])
    num = np.asarray(g.num) * (np.sum(den) / np.sum(g.den))
    return _core.TransferFunction(num, den, g.delay)


def _events(items, sc: Scenario) -> list:
    """Events in file order -> engine events; relative changes (gain, time_constant, delay)
    resolve against the truth in force at their time."""
    if not isinstance(items, list):
        _fail("events", "must be a list")
    ts, outs, ins = sc.sample_time_s, sc.outputs, sc.inputs
    parsed = []
    for k, ev in enumerate(items):
        w = f"events[{k}]"
        _obj(ev, w, None, {"time_s", "type"})
        kind = ev["type"]
        if kind not in EVENT_KEYS:
            _fail(f"{w}.type", f"unknown event type {kind!r} (known: {', '.join(EVENT_KEYS)})")
        required, optional = EVENT_KEYS[kind]
        _obj(ev, w, required | optional | {"time_s", "type"}, required)
        time_s = _num(ev["time_s"], f"{w}.time_s", minimum=0)
        sample = int(round(time_s / ts))
        if abs(sample * ts - time_s) > 1e-6 * max(ts, 1.0):
            _fail(f"{w}.time_s", f"must be a multiple of sample_time_s ({ts:g})")
        if sample >= sc.num_samples:
            _fail(f"{w}.time_s", "is after the end of the simulation")
        parsed.append((sample, k, w, kind, ev))
    parsed.sort(key=lambda p: (p[0], p[1]))
    truth = [[sc.truth.process(o, i) for i in ins] for o in outs]
    out = []
    for sample, _, w, kind, ev in parsed:
        e = _core.Event()
        e.sample = sample
        i = _name(ev["output"], f"{w}.output", outs, "output") if "output" in ev else -1
        j = _name(ev["input"], f"{w}.input", ins, "input") if "input" in ev else -1
        e.output, e.input = i, j
        if kind in CHANNEL_EVENTS:
            e.kind = _core.EventKind.process
            current = truth[i][j]
            if kind == "process":
                new = None if ev.get("model") is None else parse_transfer_function(ev["model"], f"{w}.model", ts)
            elif current is None:
                _fail(w, f"{kind} event on {ev['output']} <- {ev['input']}, a channel the truth does not have")
            elif kind == "gain":
                f = _num(ev.get("factor"), f"{w}.factor")
                new = _core.TransferFunction(np.asarray(current.num) * f, current.den, current.delay)
            elif kind == "time_constant":
                new = _scale_poles(current, _num(ev.get("factor"), f"{w}.factor", positive=True), w)
            else:
                new = _core.TransferFunction(current.num, current.den, _int(ev.get("delay"), f"{w}.delay"))
            truth[i][j] = new
            e.model = new
            switch = ev.get("switch", "replay")
            if switch not in CHANNEL_SWITCHES:
                _fail(f"{w}.switch", f"must be one of {', '.join(CHANNEL_SWITCHES)}, not {switch!r}")
            e.fresh = switch == "fresh"
        elif kind == "noise":
            e.kind = _core.EventKind.noise
            e.model = parse_transfer_function(ev["model"], f"{w}.model", ts)
        elif kind == "sigma":
            e.kind = _core.EventKind.sigma
            e.value = _num(ev.get("value"), f"{w}.value", minimum=0)
        elif kind == "drift":
            e.kind = _core.EventKind.drift
            e.value = _num(ev.get("offset", 0.0), f"{w}.offset")
            e.rate = _num(ev.get("rate_per_s", 0.0), f"{w}.rate_per_s") * ts
        elif kind == "actuator":
            e.kind = _core.EventKind.actuator
            e.actuator = _actuator(ev, w)
        elif kind == "setpoint":
            e.kind = _core.EventKind.cv_target
            e.value = _num(ev.get("value"), f"{w}.value")
        elif kind == "mv_target":
            if sc.pid_loops:
                _fail(f"{w}.type", "mv_target events need the MPC (controller.kind 'mpc')")
            e.kind = _core.EventKind.mv_target
            e.value = _num(ev.get("value"), f"{w}.value")
        else:  # extra_channel
            e.kind = _core.EventKind.extra_process
            e.input = _name(ev["extra"], f"{w}.extra", sc.extra_names, "extra variable")
            e.model = None if ev.get("model") is None else parse_transfer_function(ev["model"], f"{w}.model", ts)
        out.append(e)
    return out


def parse_scenario(spec: dict) -> Scenario:
    """Validate a scenario document (see docs/scenario.md)."""
    _obj(spec, "", TOP_KEYS, {"sample_time_s", "inputs", "outputs", "process", "truth", "controller",
                              "duration_s"})
    model = _model(spec, "", spec["process"], spec.get("noise"), spec.get("actuators"))
    ts, inputs, outputs = model.sample_time_s, list(model.inputs), list(model.outputs)
    truth = _obj(spec["truth"], "truth", TRUTH_KEYS, {"sigma"})
    truth_model = _model(spec, "truth.", truth.get("process", spec["process"]),
                         truth.get("noise", spec.get("noise")))
    sig = _obj(truth["sigma"], "truth.sigma", set(outputs), set(outputs))
    sigma = [_num(sig[o], f"truth.sigma.{o}", minimum=0) for o in outputs]
    extra_names, extra, extra_process = [], [], []
    if "extra" in truth:
        extras = _obj(truth["extra"], "truth.extra")
        extra_names = list(extras)
        for name in extra_names:
            if name in inputs or name in outputs or name == "time" or name.endswith("_sp"):
                _fail(f"truth.extra.{name}", "clashes with a data column name")
        extra_process = [[None] * len(extra_names) for _ in outputs]
        for k, name in enumerate(extra_names):
            w = f"truth.extra.{name}"
            s = _obj(extras[name], w, EXTRA_KEYS, {"operating_point", "sigma"})
            x = _core.ExtraVariable()
            x.name = name
            x.operating_point = _num(s["operating_point"], f"{w}.operating_point")
            x.sigma = _num(s["sigma"], f"{w}.sigma", minimum=0)
            if "noise" in s:
                x.noise = parse_transfer_function(s["noise"], f"{w}.noise", ts)
            extra.append(x)
            for out, tf in _obj(s.get("affects", {}), f"{w}.affects", set(outputs)).items():
                extra_process[outputs.index(out)][k] = parse_transfer_function(tf, f"{w}.affects.{out}", ts)
    actuators = []
    if "actuators" in truth:
        acts = _obj(truth["actuators"], "truth.actuators", set(inputs))
        actuators = [_actuator(_obj(acts.get(n, {}), f"truth.actuators.{n}", ACTUATOR_KEYS),
                               f"truth.actuators.{n}") for n in inputs]
    elif model.actuators_dict():
        # no true valves given: the plant has the valves the model file describes
        from .stiction.valve import nonlinearity

        valves = model.actuators_dict()
        actuators = [nonlinearity(valves[n]) if n in valves else _core.ActuatorNonlinearity() for n in inputs]
    controller = spec["controller"]
    kind = controller.get("kind", "mpc") if isinstance(controller, dict) else "mpc"
    if kind not in ("mpc", "pid"):
        _fail("controller.kind", f"must be 'mpc' or 'pid', got {kind!r}")
    tuning, pid_loops = _pid(controller, outputs, inputs) if kind == "pid" else (
        _tuning(controller, outputs, inputs), [])
    outlier_probability, outlier_size = (_outliers(truth["outliers"], outputs) if "outliers" in truth
                                         else (0.0, [0.0] * len(outputs)))
    duration = _num(spec["duration_s"], "duration_s", positive=True)
    num_samples = int(math.floor(duration / ts + 1e-9))
    if num_samples < 1:
        _fail("duration_s", "is shorter than one sample")
    # The engine counts samples in a C int and keeps every signal in memory.
    if num_samples > MAX_SAMPLES:
        _fail("duration_s", f"gives {num_samples} samples, more than {MAX_SAMPLES}")
    sc = Scenario(spec=spec, model=model, truth=truth_model, sigma=sigma,
                  extra_names=extra_names, extra=extra, extra_process=extra_process,
                  actuators=actuators, tuning=tuning, pid_loops=pid_loops,
                  outlier_probability=outlier_probability, outlier_size=outlier_size,
                  num_samples=num_samples,
                  seed=_int(spec.get("seed", 0), "seed"))
    sc.events = _events(spec.get("events", []), sc)
    return sc


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario JSON file; errors name the file and the field."""
    path = Path(path)
    try:
        spec = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not valid JSON ({exc})") from None
    try:
        return parse_scenario(spec)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
