"""A rough law written to a file and read back is the same law, to the bit; a damaged file is said to be so."""
from __future__ import annotations

import numpy as np
import pytest

from filmcal._errors import DamagedFileError
from filmcal.contact.laws import SeriesLaw
from filmcal.contact.rough_law_file import load_rough_law, save_rough_law
from filmcal.contact.roughness import RoughSurface, rough_contact_law


@pytest.fixture(scope="module")
def laws():
    a = RoughSurface.synthetic(ra_um=1.5, size_um=100.0, rolloff_wavelength_um=40.0, n=32, seed=1)
    b = RoughSurface.synthetic(ra_um=0.8, size_um=100.0, rolloff_wavelength_um=40.0, n=32, seed=2)
    return (rough_contact_law(a, 2500.0, 0.3, 0.09, n_steps=8),
            rough_contact_law(b, 2500.0, 0.3, 0.09, n_steps=8, hardness_mpa=450.0))


@pytest.mark.parametrize("series", [False, True])
def test_a_law_read_back_answers_as_the_law_written(laws, tmp_path, series):
    law = SeriesLaw(*laws) if series else laws[0]
    back = load_rough_law(save_rough_law(law, tmp_path / "law.npz"))
    assert type(back) is type(law)
    p = np.linspace(0.0, 1.5 * laws[0].saturation_pressure_mpa, 97)
    for method in ("closure_mm", "tangent_compliance_mm_per_mpa", "closure_integral"):
        assert np.array_equal(getattr(back, method)(p), getattr(law, method)(p)), method
    for mine, theirs in zip(back.laws if series else (back,), law.laws if series else (law,)):
        assert np.array_equal(mine.fraction_above(120.0, p), theirs.fraction_above(120.0, p))
        assert np.array_equal(mine.contact_fraction(p), theirs.contact_fraction(p))
        assert np.array_equal(mine.surface.heights_um, theirs.surface.heights_um)
        assert mine.describe() == theirs.describe()
    assert [f.name for f in tmp_path.iterdir()] == ["law.npz"]  # written atomically: no temporary file left


def test_a_damaged_or_foreign_file_is_refused_as_damaged(laws, tmp_path):
    path = save_rough_law(laws[0], tmp_path / "law.npz")
    path.write_bytes(path.read_bytes()[:200])
    with pytest.raises(DamagedFileError, match="law.npz is damaged"):
        load_rough_law(path)
    np.savez(tmp_path / "other.npz", x=np.arange(3))
    with pytest.raises(DamagedFileError, match="other.npz is damaged"):
        load_rough_law(tmp_path / "other.npz")
    with pytest.raises(TypeError, match="boundary-element laws"):
        save_rough_law(object(), tmp_path / "x.npz")
