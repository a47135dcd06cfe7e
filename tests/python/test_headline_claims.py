"""Guards of the recommended presets' headline claims (docs/detection.md): a seeded Monte Carlo
per preset on the paper's scenarios at seeds never used for choosing (200 on; alpha and the
training lengths were chosen on seeds 0-99 and checked on 100-199), through ``mpmpp.evaluate``,
with the presets' training lengths and with the paper's (3 h SISO, 4 h MIMO).

Margins. Each count is binomial over independent runs. A lower bound on a detection count is
the 1 % quantile of Binomial(n, 0.95) (the issue's target rate); an upper bound on a false
alarm count is the 99 % quantile of Binomial(n, p) with p = 0.05 (the target) for false MPM
alarms anywhere and p = 0.02 for MPM alarms during the noise-only change (measured 1-3 % over
100 seeds). A detector that meets the targets fails one bound with probability <= 1 %; the
seeds are fixed, so the outcome is deterministic, and a change that broke detection (or made a
noise change raise MPM alarms in a sizeable share of runs, as the paper's own presets and the
residual baseline do) fails.

Not guarded here: detection on the scenario families (docs/families.md). No preset reaches a
rate worth guarding there yet (9-57 % per family), so a bound would either be loose enough to
pass a broken detector or would lock in today's misses. tests/python/test_detection_families.py guards the
false-alarm side on held-out families (no MPM alarm during held-out noise changes).
"""
import math

import pytest
from scipy.stats import binom

from mpmpp.evaluate import evaluate

TARGET_DETECTION = 0.95
TARGET_FALSE_MPM = 0.05
NOISE_CHANGE_MPM = 0.02
RISK = 0.01


def at_least(n: int, rate: float = TARGET_DETECTION) -> int:
    """Largest k with P(X < k) <= RISK for X ~ Binomial(n, rate)."""
    return int(binom.ppf(RISK, n, rate))


def at_most(n: int, rate: float) -> int:
    """Smallest k with P(X > k) <= RISK for X ~ Binomial(n, rate)."""
    return int(binom.isf(RISK, n, rate))


def below(k: int, n: int, rate: float) -> float:
    """P(X < k), summed term by term."""
    return sum(math.comb(n, j) * rate**j * (1 - rate) ** (n - j) for j in range(k))


def test_margins():
    # The quantile helpers against direct sums of the binomial probabilities.
    for n, rate in ((100, 0.95), (60, 0.95)):
        k = at_least(n, rate)
        assert below(k, n, rate) <= RISK < below(k + 1, n, rate)
    for n, rate in ((100, 0.05), (60, 0.02)):
        k = at_most(n, rate)
        assert 1 - below(k + 1, n, rate) <= RISK < 1 - below(k, n, rate)


def counts(summary, channel):
    n = summary["seeds"]
    row = next(r for r in summary["rows"] if r["method"] == "svm" and r["channel"] == channel)
    detected = None if row["detection_rate"] is None else round(row["detection_rate"] * n)
    return detected, round(row["false_alarm_rate"] * n)


G11, G31 = "G[press_dry_weight <- stock_flow]", "G[reel_moisture <- stock_flow]"


@pytest.mark.parametrize("scenario,config,seeds,changed,noise", [
    # The gain doubling at 11 h, the noise change of dry_weight at 7 h.
    ("paper_siso", "siso", range(200, 300), {"G[dry_weight <- stock_flow]": TARGET_DETECTION}, "H[dry_weight]"),
    # G11 doubled at 20.83 h, G31 at 16.67 h, the noise change of press_moisture at 9.58 h.
    ("paper_mimo", "mimo", range(200, 260), {G11: TARGET_DETECTION, G31: TARGET_DETECTION}, "H[press_moisture]"),
    # The paper's own training lengths (Table 1: 3 h, Table 3: 4 h) with the recommended presets.
    # G31 with 4 h of training: 29 of 30 with the whitening at the disturbance's order (30 of
    # 30 with AR(18); 21 of 30 before the model as reference, when its bound was the 1 %
    # quantile at 0.75).
    ("paper_siso", {"preset": "siso", "train_duration_s": 3 * 3600.0}, range(300, 400),
     {"G[dry_weight <- stock_flow]": TARGET_DETECTION}, "H[dry_weight]"),
    ("paper_mimo", {"preset": "mimo", "train_duration_s": 4 * 3600.0}, range(300, 330),
     {G11: TARGET_DETECTION, G31: TARGET_DETECTION}, "H[press_moisture]"),
], ids=["siso", "mimo", "siso-3h-training", "mimo-4h-training"])
def test_recommended_preset_meets_its_claims(scenario, config, seeds, changed, noise):
    s = evaluate(scenario, seeds, config, workers=2, progress=False)
    n = s["seeds"]
    for channel, rate in changed.items():
        detected, _ = counts(s, channel)
        assert detected >= at_least(n, rate), f"{channel}: detected in {detected} of {n} runs"
    detected, _ = counts(s, noise)
    assert detected >= at_least(n), f"{noise}: noise change detected in {detected} of {n} runs"
    false_mpm = round(s["svm"]["any_false_mpm_rate"] * n)
    assert false_mpm <= at_most(n, TARGET_FALSE_MPM), f"false MPM alarm in {false_mpm} of {n} runs"
    during_noise = round(s["svm"]["noise_change_alarm_rate"] * n)
    assert during_noise <= at_most(n, NOISE_CHANGE_MPM), f"MPM alarm during the noise change in {during_noise} of {n}"
    false_noise = round(s["svm"]["any_false_noise_rate"] * n)
    assert false_noise <= at_most(n, TARGET_FALSE_MPM), f"false noise alarm in {false_noise} of {n} runs"
