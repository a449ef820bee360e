"""The planar layouts (daebench.models.sliderslot, daebench.models.rodplate) against their
scenes' geometry: each body's lumped mass ρ·A·t from the stated dimensions (a round end's area
as a half disc, which the mesh's polygon approaches from inside), the start's momentum
m·v₀ along the stated direction, and a gap at the start equal to the stated one."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.models import build_system
from daebench.models.scenes import load_scene


def _momentum(s, v):
    d = np.asarray(s.lumped_mass)
    return float(d[0::2] @ v[0::2]), float(d[1::2] @ v[1::2])


def test_slider_slot_mass_and_launch():
    sc = load_scene("slider-slot")
    s = build_system(sc)
    q, v = s.initial_state()
    L, w, t, rho = sc["slider.length"], sc["slider.width"], sc["slider.thickness"], sc["slider.density"]
    area = (L - w / 2) * w + math.pi * (w / 2) ** 2 / 2          # body + semicircular head
    m = rho * area * t
    total = float(np.sum(s.lumped_mass))
    assert total == pytest.approx(2.0 * m, rel=2e-2) and total < 2.0 * m   # (x and y per node)
    a = math.radians(sc["start.angle_deg"])
    px, py = _momentum(s, v)
    assert (px, py) == (pytest.approx(total / 2 * sc["start.speed"] * math.cos(a), rel=1e-12),
                        pytest.approx(total / 2 * sc["start.speed"] * math.sin(a), rel=1e-12))
    assert np.all(s.gap(q) > 0.0)   # inside the slot, no wall touched


def test_rod_plate_masses_and_start():
    sc = load_scene("rod-plate")
    s = build_system(sc)
    q, v = s.initial_state()
    d, L = sc["rod.diameter"], sc["rod.length"]
    rod = sc["rod.density"] * ((L - d / 2) * d + math.pi * (d / 2) ** 2 / 2) * sc["rod.thickness"]
    plate = sc["plate.density"] * sc["plate.side"] * sc["plate.thickness"] * sc["plate.side"]
    total = float(np.sum(s.lumped_mass)) / 2
    assert total == pytest.approx(rod + plate, rel=1e-2)
    moving = np.abs(v) > 0
    assert v[moving].size and np.allclose(np.abs(v[moving]), sc["start.speed"])   # only the rod moves, at v₀
    px, py = _momentum(s, v)
    assert math.hypot(px, py) == pytest.approx(rod * sc["start.speed"], rel=1e-2)
    assert np.min(s.gap(q)) == pytest.approx(sc["start.gap"], rel=1e-6)
