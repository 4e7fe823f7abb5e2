"""The no-gate replication of the TOM-IMM chapter (tom-imm-houles-pg1-rep): a new seed,
the count declared before it ran, and the same filters and environment as
tom-imm-houles-pg1."""
from trackcore.experiments import get, load, verify_sample
from trackcore.experiments.tom_pg1 import REP_SEED, SEED


def test_the_replication_is_declared_on_a_new_seed():
    e, first = get("tom-imm-houles-pg1-rep"), get("tom-imm-houles-pg1")
    assert (e.seed, e.runs, e.version) == (REP_SEED, 10000, "1"), e
    assert REP_SEED != SEED, "the replication must not reuse Table 1's seed"
    assert e.config == first.config, "the replication changes the filters or environment"


def test_the_replication_store_verifies():
    r = load("tom-imm-houles-pg1-rep")
    assert r.runs == 10000, r.runs
    assert verify_sample(r, indices=[0, 9999]).checked == 2, "stored rows differ"
