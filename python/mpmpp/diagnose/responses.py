"""Whitened responses of the candidate shapes (``shapes``), cached per output and search."""
from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from .._core import TransferFunction
from .shapes import DELAY_GRID_EFFECTS, Shape, drift_drive
from .whitening import Nuisance, OutputResidual


@dataclass
class DelayFamily:
    """One channel shape without delay, driven by one column: the shapes that differ from it
    only in their delay are delayed copies of its responses."""

    response: np.ndarray = field(repr=False)   # channel response per data segment
    whitened: np.ndarray = field(repr=False)   # and whitened per piece
    # piece -> the response from its segment's start whitened with that piece's filter (for a
    # piece that starts inside a segment; ShapeResponses._inside_segment)
    from_segment_start: dict = field(repr=False, default_factory=dict)


@dataclass
class WhitenedShape:
    psi: np.ndarray                     # whitened response of the candidate shape
    nominal: np.ndarray | None          # whitened response of the nominal channel it replaces


class ShapeResponses:
    """Whitened responses and weights per shape; they do not change between the greedy rounds,
    only the residual does. Gain and time-constant responses are kept; shapes on a grid of
    delays or drift onsets (hundreds in a long record) are rebuilt on demand from one response
    per family. The scans take a response unprojected and project it in their pass."""

    def __init__(self, out: OutputResidual, nuisance: Nuisance):
        self.out = out
        self.nuisance = nuisance
        self.project = nuisance.project
        self._shapes: dict = {}
        self._nominal: dict = {}
        self._weight: dict = {}
        self._piece_drifts: dict = {}
        self._delay_families: dict = {}
        self._segment_starts = {a for a, _ in out.sig.segments}
        # a constant output error, whitened: the nuisance's level column (disturbance_drives' first)
        self.level = nuisance.columns[:, 0]

    def level_step(self, onset: int) -> np.ndarray:
        """The output's level step at ``onset``, whitened and projected (the second regressor of
        ``ProjectedOnsetScan.fit_with_level_step``)."""
        return self.project(np.where(np.arange(len(self.level)) >= onset, self.level, 0.0))

    def beside(self, nuisance: Nuisance) -> ShapeResponses:
        """The same responses fitted beside other disturbances: what is not projected is shared
        (``_Search.disturbances`` fits the first round beside up to three sets)."""
        other = copy.copy(self)
        other.nuisance, other.project, other._nominal = nuisance, nuisance.project, {}
        return other

    def whitened(self, shape: Shape) -> WhitenedShape:
        """The shape's whitened response and its nominal channel's, both projected."""
        return WhitenedShape(self.project(self.response(shape)), self.nominal_response(shape))

    def response(self, shape: Shape) -> np.ndarray:
        """The shape's whitened response, not projected."""
        if shape.kind == "drift":
            return self._drift(int(shape.label), shape.drift_form)
        if shape.effect in DELAY_GRID_EFFECTS:
            return self._delayed(shape)
        key = _channel_key(shape, shape.shape)
        if key not in self._shapes:
            drive = np.nan_to_num(shape.drive)
            self._shapes[key] = self.out.whiten(self.out.channel_response(shape.shape, drive))
        return self._shapes[key]

    def nominal_response(self, shape: Shape) -> np.ndarray | None:
        """The whitened, projected response of the nominal channel the shape replaces."""
        if shape.nominal is None:
            return None
        key = _channel_key(shape, shape.nominal)   # by value, as the candidates' responses
        if key not in self._nominal:
            self._nominal[key] = self.project(
                self.out.whiten(self.out.channel_response(shape.nominal, np.nan_to_num(shape.drive))))
        return self._nominal[key]

    def _delayed(self, shape: Shape) -> np.ndarray:
        """Whitened response of a delayed channel. In a piece that starts a data segment, the
        channel and the whitening filter start at rest and see zeros for the first ``delay``
        samples, so the response is the undelayed one, delayed; a piece that starts inside a
        segment (after a noise split) inherits the channel's history (``_inside_segment``)."""
        out, g = self.out, shape.shape
        undelayed = TransferFunction(g.num, g.den, 0)
        key = _channel_key(shape, undelayed)
        if key not in self._delay_families:
            x = out.channel_response(undelayed, np.nan_to_num(shape.drive))
            self._delay_families[key] = DelayFamily(x, out.whiten(x))
        family, d = self._delay_families[key], g.delay
        psi = np.zeros(len(out.r))
        for p, (a, b) in enumerate(out.pieces):
            if a in self._segment_starts:
                if d < b - a:
                    psi[a + d:b] = family.whitened[a:b - d]
            else:
                psi[a:b] = self._inside_segment(family, p, d)
        return psi

    def _inside_segment(self, family: DelayFamily, p: int, d: int) -> np.ndarray:
        """The delayed channel's whitened response on piece p, which starts inside a data
        segment: the piece's filter starts at rest at the piece while the channel has run since
        the segment's start. Once the filter has forgotten its start (``forgetting_rows``) this
        is the response whitened from the segment's start (once per family and piece), delayed;
        only the rows before are filtered here. Filtering every delay's piece directly cost a
        third of diagnose on a week of 3x3 data after a noise split (1,920 coupling shapes)."""
        out = self.out
        a, b = out.pieces[p]
        s0 = self._segment_start(a)
        if p not in family.from_segment_start:
            family.from_segment_start[p] = out.whiten_piece(p, family.response[s0:b])
        restarted = family.from_segment_start[p]
        start = max(a, s0 + d)
        piece = np.zeros(b - a)
        if start > a:   # the channel's input reaches it after the piece starts: no history
            piece[start - a:] = restarted[:b - start]
            return piece
        head = a + out.forgetting_rows(p)
        piece[:head - a] = out.whiten_piece(p, family.response[a - d:head - d])
        piece[head - a:] = restarted[head - d - s0:b - d - s0]
        return piece

    def _segment_start(self, t: int) -> int:
        return max(a for a in self._segment_starts if a <= t)

    def _drift(self, onset: int, form: str) -> np.ndarray:
        """Whitened response of a ramp (per hour) or step starting at ``onset``. In the piece
        holding the onset the whitening filter starts at rest and sees zeros until the onset,
        so the response there is the piece's response to a drift starting at its first sample,
        delayed. A later piece restarts its filter on a drift under way: a step is 1 there and
        a ramp (t - a)/hour plus its level (a - onset)/hour, so by linearity its response is the
        piece's response to a drift from its first sample plus that level times the piece's
        response to a constant (each onset's later pieces filtered directly took 0.23 s of the
        week of 3x3 data in bench/diagnose_speed.py, 0.11 s so)."""
        out = self.out
        psi = np.zeros(len(out.r))
        for p, (a, b) in enumerate(out.pieces):
            if b <= onset:
                continue
            if a <= onset:
                psi[onset:b] = self._piece_drift(p, form)[: b - onset]
            elif form == "ramp":
                level = (a - onset) / out.sig.samples_per_hour
                psi[a:b] = self._piece_drift(p, "ramp") + level * self._piece_drift(p, "constant")
            else:
                psi[a:b] = self._piece_drift(p, "constant")
        return psi

    def _piece_drift(self, p: int, form: str) -> np.ndarray:
        """Piece p's whitened response to a ramp or step starting at its first sample, or to a
        constant 1 (once per piece)."""
        if (p, form) not in self._piece_drifts:
            a, b = self.out.pieces[p]
            drive = np.ones(b - a) if form == "constant" else drift_drive(b - a, 0, form, self.out.sig.samples_per_hour)
            self._piece_drifts[p, form] = self.out.whiten_piece(p, drive)
        return self._piece_drifts[p, form]

    def weight(self, shape: Shape) -> np.ndarray:
        """The output's weight where the shape's drive is known (model inputs and drifts are
        known wherever the output's weight is nonzero)."""
        if shape.kind != "extra":
            return self.out.weight
        key = id(shape.drive)
        if key not in self._weight:
            self._weight[key] = self.out.weight * np.isfinite(shape.drive)
        return self._weight[key]


def _channel_key(shape: Shape, g: TransferFunction) -> tuple:
    """Cache key of channel g driven by the shape's column: by value, not by the shape's id. A
    refined time constant's shapes live only while they are fitted, and a later one created at
    a freed one's address took its cached response (tuning pi_siso_rough, 3 of 50 runs: the
    refined factor moved with the process's allocation history). The drive is a column of the
    data, alive while the responses are."""
    return id(shape.drive), tuple(np.asarray(g.num, float)), tuple(np.asarray(g.den, float)), g.delay
