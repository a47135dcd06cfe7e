"""The process classes ``identify`` fits per output (docs/identify.md "Method"): first order plus
dead time, and the integrating forms of a level. Each reads its fitted channel as gain (or rate
gain), time constant and dead time (``mpmpp.foptd``)."""
from __future__ import annotations

from dataclasses import dataclass

from .foptd import foptd_reading, integrating_reading


@dataclass(frozen=True)
class ProcessClass:
    """A channel's model class: whether the output integrates it, the denominator order nf of
    the part that is fitted (of G, or of G' = (1 - q^-1) G for an integrating output), and the
    parameters per channel BIC counts. A class is counted as the self-regulating family it is the
    boundary of: K e^(-theta s) / s is K tau e^(-theta s) / (tau s + 1) as tau -> infinity, so
    it has first order plus dead time's three (the limit is not a simpler model: on routine
    closed-loop data a flow loop's one-step errors fit both equally, and two parameters made the
    integrator win there); with a lag it is the limit of two lags, four.

    An integrating output's disturbance either integrates too (an unmeasured inflow: H = 1 /
    (A (1 - q^-1)), fitted on the differenced output) or does not (transmitter noise, waves on the
    surface: H = 1 / A, fitted on the output with the input integrated, y = G' (u / (1 - q^-1)));
    ``noise_integrates`` says which."""
    name: str
    integrating: bool
    nf: int
    parameters: int
    noise_integrates: bool = True

    def reading(self, b, f, delay, ts):
        """(K, tau, theta) of a channel fitted in this class (numerator b, denominator f, delay in
        samples, at ``ts``), or None when it is not of the class's form."""
        return (integrating_reading if self.integrating else foptd_reading)(b, f, delay, ts)


SELF_REGULATING = ProcessClass("first order plus dead time", False, 1, 3)
INTEGRATING = ProcessClass("integrating plus dead time", True, 0, 3)
INTEGRATING_LAG = ProcessClass("integrating with first-order lag plus dead time", True, 1, 4)
INTEGRATING_OUTPUT_NOISE = ProcessClass("integrating plus dead time, disturbance at the output", True, 0, 3,
                                        noise_integrates=False)
PROCESS_CLASSES = (SELF_REGULATING, INTEGRATING, INTEGRATING_LAG, INTEGRATING_OUTPUT_NOISE)
CLASSES_BY_NAME = {"auto": PROCESS_CLASSES, "self-regulating": (SELF_REGULATING,),
                   "integrating": (INTEGRATING, INTEGRATING_LAG, INTEGRATING_OUTPUT_NOISE)}
