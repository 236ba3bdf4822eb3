"""Design of experiments: optimal Latin hypercubes in named design spaces.

- `Parameter`, `DesignSpace`, `parse_parameter`: named parameters (linear or
  log range, discrete levels, fixed value) and the map to the unit cube.
- `OptimalLatinHypercube`: a sampler in ``[0, 1)^d`` in the style of
  `scipy.stats.qmc`, optimising cell-centred Latin hypercubes with the ESE
  algorithm on ``phi_p``, and augmenting existing designs.
- Metrics in the unit cube: `min_distance`, `phi_p`, `centered_l2`,
  `max_abs_correlation`, `is_latin`, `design_quality`.
- `latin_design`, `augment_design`, `read_design_csv`, `write_design_csv`:
  designs in physical values and their CSV files.
"""
from filmcal.doe.design import (Design, augment_design, latin_design, read_design_csv,
                                write_design_csv)
from filmcal.doe.lhs import OptimalLatinHypercube
from filmcal.doe.metrics import (DesignQuality, centered_l2, design_quality, is_latin,
                                 max_abs_correlation, min_distance, phi_p)
from filmcal.doe.space import DesignSpace, Parameter, parse_parameter

__all__ = [
    "Parameter", "DesignSpace", "parse_parameter",
    "OptimalLatinHypercube",
    "min_distance", "phi_p", "centered_l2", "max_abs_correlation", "is_latin",
    "DesignQuality", "design_quality",
    "Design", "latin_design", "augment_design", "read_design_csv", "write_design_csv",
]
