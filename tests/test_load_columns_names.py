"""A load column asked for by a wrong name names the right ones (a two-body joint's loads are
'<joint>@<body>.F_x'); it stays a KeyError for code that catches one."""
from __future__ import annotations

import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.mechanics.load_columns import load_columns


def _cart_pole_equations():
    model = oc.Model("cart_pole", gravity=(0, -9.81, 0))
    cart = model.add_body("cart", 1.0, 0.01 * np.eye(3), rotation="321")
    pole = model.add_body("pole", 0.5, np.diag([0.04, 1e-4, 0.04]), rotation="321")
    oc.joints.prismatic(model, "rail", cart.com, axis=(1, 0, 0))
    oc.joints.revolute(model, "hinge", pole.point("A", (0, 0.5, 0)), axis=(0, 0, 1), other=cart.com)
    return oc.SystemEquations(model)


def test_a_two_body_joint_load_asked_without_its_body_names_both_columns():
    eqs = _cart_pole_equations()
    cols = load_columns(eqs, np.zeros(2), np.zeros((2, eqs.nq)), np.zeros((2, eqs.nu)), np.zeros((2, eqs.nc)))
    with pytest.raises(oc.ModelError, match=r"no load column named 'hinge.F_x'; did you mean "
                                            r"'hinge@cart.F_x', 'hinge@pole.F_x'") as info:
        cols["hinge.F_x"]
    assert isinstance(info.value, KeyError)
    assert "hinge@pole" in str(info.value) and not str(info.value).startswith('"')


def test_a_misspelt_column_gets_the_closest_names_and_existing_ones_still_read():
    eqs = _cart_pole_equations()
    cols = load_columns(eqs, np.zeros(1), np.zeros((1, eqs.nq)), np.zeros((1, eqs.nu)), np.zeros((1, eqs.nc)))
    with pytest.raises(KeyError, match=r"'rail.F_x'"):
        cols["rial.F_x"]
    assert cols["rail.F_y"].shape == (1,) and cols.get("nothing") is None
