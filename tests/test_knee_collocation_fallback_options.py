"""A failed collocation falls back to the static optimisation *of the same problem*: the options the two
share (reserve weights, the contact forces' signs) reach the fallback, so a non-default weight never
silently becomes the default one there."""
import numpy as np
import pytest

import ocp_constraints.biomech.knee_collocation as kc
import ocp_constraints.biomech.knee_static as ks
from ocp_constraints.errors import KneeError


def test_the_static_fallback_gets_the_collocations_reserve_weights_and_contact_signs(monkeypatch):
    seen = {}

    def failing(*args, **kwargs):
        raise KneeError("collocation failed: IPOPT status 'Maximum_Iterations_Exceeded'")

    def static(*args, **kwargs):
        seen.update(kwargs)
        return ks.StaticResult.__new__(ks.StaticResult)

    monkeypatch.setattr(kc, "solve_collocation", failing)
    monkeypatch.setattr(ks, "solve_static", static)
    weights = np.full((3, len(ks.RESERVED)), 0.25)
    res = kc.solve_collocation_or_static(np.arange(3.0), None, None, None, None, reserve_weight=weights,
                                         contact_nonnegative=False, tau_act=0.01)
    assert seen["reserve_weight"] is weights and seen["contact_nonnegative"] is False
    assert "tau_act" not in seen                      # collocation-only options stay behind
    assert "Maximum_Iterations_Exceeded" in res.fallback


def test_other_failures_are_not_hidden_by_the_fallback(monkeypatch):
    monkeypatch.setattr(kc, "solve_collocation", lambda *a, **k: (_ for _ in ()).throw(KneeError("bad muscle data")))
    with pytest.raises(KneeError, match="bad muscle data"):
        kc.solve_collocation_or_static(np.arange(3.0), None, None, None, None)
