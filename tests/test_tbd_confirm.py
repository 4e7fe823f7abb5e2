"""The TBD chapter's confirmation set (003-06, declared in session 8 before its runs)."""
from trackcore.experiments import get, names
from trackcore.experiments.tbd_grid import CONFIRM_RUNS, CONFIRM_SEED, TbdGridConfig


def test_the_confirmation_set_is_declared_as_fixed():
    exp = get("tbd-grid-confirm-base-25")
    assert (exp.runs, exp.seed) == (5000, 20161307), "5000 runs of seed 20161307 declared"
    assert (CONFIRM_RUNS, CONFIRM_SEED) == (exp.runs, exp.seed), "constants and registry"
    assert exp.config == TbdGridConfig(), "the book's A, B, C, baseline, R = 2.5 km"


def test_the_confirmation_seed_is_used_by_no_other_tbd_experiment():
    others = {get(n).seed for n in names() if n.startswith("tbd-") and "confirm" not in n}
    assert CONFIRM_SEED not in others, "the confirmation set must be fresh runs"
    assert not 7_300_000 <= CONFIRM_SEED < 7_400_000, "nor a seed of the independent rerun (7_300_000 + k)"
