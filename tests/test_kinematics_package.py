"""``kinserve.kinematics`` loads its public names on first use (PEP 562): each name is its submodule's object,
the submodules are reachable as attributes, and importing the error classes imports no solver."""

from __future__ import annotations

import importlib

import pytest

import kinserve.kinematics as kinematics

from import_probe import imported_after


@pytest.mark.parametrize("name", kinematics.__all__)
def test_each_public_name_is_its_submodules_object(name):
    value = getattr(kinematics, name)
    home = kinematics._HOMES.get(name)
    if home is None:
        assert value is importlib.import_module(f"kinserve.kinematics.{name}")
    else:
        assert value is getattr(importlib.import_module(f"kinserve.kinematics.{home}"), name)
    assert name in dir(kinematics)


def test_every_public_name_has_one_home():
    assert sorted(kinematics.__all__) == sorted([*kinematics._HOMES, *kinematics._SUBMODULES])


def test_submodules_are_attributes_and_unknown_names_are_attribute_errors():
    assert kinematics.collision_scene is importlib.import_module("kinserve.kinematics.collision_scene")
    with pytest.raises(AttributeError, match="has no attribute 'no_such_name'"):
        kinematics.no_such_name  # noqa: B018
    assert not hasattr(kinematics, "_no_such_private")
    from kinserve.kinematics import Box, errors  # the from-import forms

    assert errors.InputError is kinematics.InputError and Box is kinematics.shapes.Box


def test_the_errors_import_no_solver():
    code = "from kinserve.kinematics.errors import InputError\nfrom kinserve.kinematics import KinserveError"
    assert imported_after(code, ("numba", "pinocchio", "scipy", "kinserve.kinematics.robot"))[0] == []
