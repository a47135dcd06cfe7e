"""Which process class an output gets (docs/identify.md "Method", "When the class is open"):
first order plus dead time unless an integrating class wins clearly, and what the other class
would read when the data leave the choice open."""
from __future__ import annotations

from dataclasses import dataclass

from .channel_reading import ChannelSummary, against_controller
from .process_class import INTEGRATING, SELF_REGULATING, ProcessClass
from .structure_search import PRUNE, Candidate


# BIC difference (2 log Bayes factor) an integrating class needs over an identified first-order
# fit: "strong" evidence on Kass & Raftery's scale (JASA 1995)
CLASS_MARGIN = 6.0
# BIC difference the disturbance at the output needs over an inflow disturbance for an integrating
# output: "very strong" on the same scale (on routine tank records the two forms are confused
# within 8)
OUTPUT_NOISE_MARGIN = 10.0


@dataclass
class ClassFit:
    cls: ProcessClass
    best: Candidate
    channels: list[ChannelSummary]
    action: int = 0              # the controller's action the data show (SISO), 0 when unknown

    @property
    def identified(self) -> bool:
        """A gain distinguishable from 0 that the controller's action admits: a class whose fit
        follows the feedback path (sign guard) identifies nothing, so it cannot take the place
        of another class in ``choose_class``."""
        return any(c.significant for c in self.channels) and not against_controller(self.channels, self.action)


def choose_class(fitted: list[ClassFit], duration_s: float, sample_time_s: float):
    """(class, candidate, channel summaries) of the BIC-best class, except that an integrating
    output's disturbance is an inflow (it integrates) unless the disturbance at the output scores
    better by OUTPUT_NOISE_MARGIN, and that first order plus
    dead time (the default, fitted first) gives way to another class only by a BIC better by
    CLASS_MARGIN when it identifies something; when it identifies nothing, the best identified
    other class takes its place if its BIC is lower, or if first order ran to its integrating
    boundary (every time constant longer than the record: no settling seen, the gain lost in the
    trade-off with tau), or if its every channel has a dead time of a sample or more: a rate the
    data determine, through a transport delay of its own, is an integrating loop whose first-order
    fit lost its gain to a pole near 1 (level loops with a sticking valve, tuning flow and level
    loops of studies/stiction_benchmark.py: 5 of 6 refused before), while an integrator without
    dead time is how a fast self-regulating loop under integral control can look (the tuning
    linear flow loops: rate gain 1.3 per sample, dead time 0; still refused).
    Without excitation a PI loop's one-step errors hardly tell the classes
    apart (the noise model absorbs the difference: routine data of a flow loop fit an integrator
    with theta = 0 within a BIC of 3 on 3 of 20 seeds)."""
    inflow = [f.best.bic for f in fitted if f.cls.integrating and f.cls.noise_integrates and f.identified]
    if inflow:
        fitted = [f for f in fitted if f.cls.noise_integrates or f.best.bic < min(inflow) - OUTPUT_NOISE_MARGIN]
    default, best = fitted[0], min(fitted, key=lambda f: f.best.bic)
    if default.cls is not SELF_REGULATING:
        return best.cls, best.best, best.channels
    if default.identified:
        if best is not default and best.best.bic > default.best.bic - CLASS_MARGIN:
            best = default
    else:
        others = [f for f in fitted[1:] if f.identified]
        at_boundary = all(c.time_constant_s > duration_s for c in default.channels)
        delayed = [f for f in others if all(c.dead_time_s >= sample_time_s for c in f.channels if c.significant)]
        if others and (at_boundary or min(f.best.bic for f in others) < default.best.bic):
            best = min(others, key=lambda f: f.best.bic)
        elif delayed:
            best = min(delayed, key=lambda f: f.best.bic)
    return best.cls, best.best, best.channels


def lag_worth_searching(fitted: list[ClassFit]) -> bool:
    """Whether to search the integrator with a lag: not when the pure integrator trails first order
    by more than PRUNE. First order reaches the pure integrator as tau -> infinity, and neither
    has a second lag, so a lagged integrator leaves the two close; a wide gap says the output
    settles, which a lag on an integrator cannot make up."""
    bic = {f.cls: f.best.bic for f in fitted}
    return not (SELF_REGULATING in bic and INTEGRATING in bic and bic[INTEGRATING] > bic[SELF_REGULATING] + PRUNE)


def integrating_alternative(fitted: list[ClassFit], chosen: ProcessClass) -> str:
    """For a refusal: what an identified integrating class would say, when the data leave the
    class open (a slow lag and an integrator look alike in a short closed-loop record)."""
    others = [f for f in fitted if f.cls.integrating and f.cls is not chosen and f.identified]
    if chosen.integrating or not others:
        return ""
    chans = [c for c in min(others, key=lambda f: f.best.bic).channels if c.significant]
    return ("; as an integrating process: "
            + ", ".join(f"rate gain {c.gain:.3g} +- {c.gain_sd:.2g} per s from {c.input!r}, dead time "
                        f"{c.dead_time_s:.3g} s" for c in chans)
            + " (--process integrating writes that model)")


def settling_alternative(fitted: list[ClassFit], chosen: ProcessClass) -> str | None:
    """For an integrating class chosen: what first order plus dead time reads when it fits the
    data better by CLASS_MARGIN or more and was passed over because it identifies nothing
    (``choose_class``). In a short closed-loop record a slow settling process and an integrator
    look alike; the integrator's rate can be firm where first order's gain is not, yet the
    one-step errors favour settling. Routine pressure-like PI loops (tau 120 s, 2 h at 10 s,
    studies/identify_study.py seeds 1-4) were called integrating with first order better by 12-17
    (gain -2.85 +- 1.4 for a true -2.5) and a simulation fit of -354 % to -940 %. Taking first
    order there instead also refused true levels of the stiction study, and first order fits
    better by CLASS_MARGIN on many true levels with a sticking valve (docs/identify.md "When the
    class is open"), so the choice stays and the summary says the class is open."""
    first = next((f for f in fitted if f.cls is SELF_REGULATING), None)
    taken = next((f for f in fitted if f.cls is chosen), None)
    if not chosen.integrating or first is None or taken is None:
        return None
    margin = taken.best.bic - first.best.bic
    if not margin >= CLASS_MARGIN:
        return None
    return (f"first order plus dead time fits these data better by {margin:.1f} in BIC but does not determine "
            "its gain (" + ", ".join(f"{c.gain:.3g} +- {c.gain_sd:.2g} from {c.input!r}, time constant "
                                     f"{c.time_constant_s:.3g} s" for c in first.channels)
            + "); over this record a slow settling process and an integrator look alike "
            "(--process self-regulating tries that class)")
