"""Comparing generated files by their parsed values, with a tolerance: another machine's floats differ
in the 15th digit (``1.85e-15`` against ``0.0``), so generated files are never compared byte for byte."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np


def _floats(text: str) -> list[float] | None:
    try:
        return [float(x) for x in text.split()]
    except ValueError:
        return None


def assert_xml_close(a: str, b: str, tol: float = 1e-6) -> None:
    """Two XML texts with the same elements and attributes, numbers equal within ``tol`` (abs and rel)."""
    def walk(x: ET.Element, y: ET.Element, where: str) -> None:
        assert x.tag == y.tag, f"{where}: element {x.tag} against {y.tag}"
        assert set(x.attrib) == set(y.attrib), \
            f"{where}/{x.tag}: attributes {sorted(x.attrib)} against {sorted(y.attrib)}"
        for k, va in x.attrib.items():
            vb = y.attrib[k]
            fa, fb = _floats(va), _floats(vb)
            if fa is not None and fb is not None and len(fa) == len(fb):
                assert np.allclose(fa, fb, rtol=tol, atol=tol), f"{where}/{x.tag}@{k}: {va} against {vb}"
            else:
                assert va == vb, f"{where}/{x.tag}@{k}: {va!r} against {vb!r}"
        kx, ky = list(x), list(y)
        assert len(kx) == len(ky), f"{where}/{x.tag}: {len(kx)} children against {len(ky)}"
        for i, (cx, cy) in enumerate(zip(kx, ky)):
            walk(cx, cy, f"{where}/{x.tag}[{i}]")

    walk(ET.fromstring(a), ET.fromstring(b), "")


def assert_text_close(a: str, b: str, decimals: int) -> None:
    """Two generated texts (BVH) token by token: words equal, numbers within one unit of the last
    written decimal (a value on a rounding edge may round either way on another machine)."""
    ta, tb = a.split(), b.split()
    assert len(ta) == len(tb), f"{len(ta)} tokens against {len(tb)}"
    tol = 1.01 * 10.0 ** -decimals
    for i, (x, y) in enumerate(zip(ta, tb)):
        if x == y:
            continue
        try:
            fx, fy = float(x), float(y)
        except ValueError:
            raise AssertionError(f"token {i}: {x!r} against {y!r}") from None
        assert abs(fx - fy) <= tol, f"token {i}: {x} against {y} (tolerance {tol:g})"
