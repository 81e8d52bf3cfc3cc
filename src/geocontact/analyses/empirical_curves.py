"""The modulus reduction and damping curves geotechnical engineers use, beside the DEM's:

- Darendeli (2001), "Development of a new family of normalized modulus reduction and material
  damping curves", PhD thesis, University of Texas at Austin: taken from the site-response
  library ``pystrata`` (its ``DarendeliSoilType``, Kottke et al.), not written again; a clean
  sand is PI = 0, OCR = 1.
- Hardin & Drnevich (1972), "Shear modulus and damping in soils: design equations and curves",
  J. Soil Mech. Found. Div. ASCE 98(SM7), 667-692: the hyperbola G/Gmax = 1 / (1 + γ/γr)
  (pystrata has no such class; it is one line). Its damping here is Masing's for that hyperbola
  (Darendeli 2001, eq. 9.5 with curvature 1), so that the two curves differ only in their shape:
  the hyperbola is drawn with Darendeli's reference strain at the same mean stress.
"""

from __future__ import annotations

import math

import numpy as np

ATMOSPHERE_PA = 101_325.0


def darendeli(strains: np.ndarray, mean_stress_Pa: float, plasticity_index: float = 0.0,
              ocr: float = 1.0, frequency_Hz: float = 1.0,
              cycles: int = 10) -> dict[str, np.ndarray | float]:
    """G/Gmax and D (decimal) of Darendeli (2001) at the shear strains ``strains`` (decimal),
    through pystrata; with its reference strain (decimal) and minimum damping."""
    from pystrata.site import DarendeliSoilType

    soil = DarendeliSoilType(plas_index=plasticity_index, ocr=ocr,
                             stress_mean=mean_stress_Pa / 1e3, freq=frequency_Hz,
                             num_cycles=cycles, strains=np.asarray(strains, dtype=float))
    return {"strain": np.asarray(soil.mod_reduc.strains, dtype=float),
            "G_over_Gmax": np.asarray(soil.mod_reduc.values, dtype=float),
            "damping_ratio": np.asarray(soil.damping.values, dtype=float),
            "reference_strain": float(soil.strain_ref),
            "damping_min": float(np.min(soil.damping.values))}


def hardin_drnevich(strains: np.ndarray, reference_strain: float) -> dict[str, np.ndarray]:
    """The hyperbola of Hardin & Drnevich (1972), G/Gmax = 1 / (1 + γ/γr), and the Masing
    damping of that hyperbola, D = (4/π) (1 + 1/x) (1 − ln(1 + x)/x) − 2/π with x = γ/γr."""
    x = np.asarray(strains, dtype=float) / reference_strain
    modulus = 1.0 / (1.0 + x)
    # for x -> 0 the bracket cancels to x/3 - ...: its series keeps small strains exact
    small = x < 1e-4
    xs = np.where(small, 1.0, x)
    masing = (4 / math.pi) * (1 + 1 / xs) * (1 - np.log1p(xs) / xs) - 2 / math.pi
    masing = np.where(small, (2 / (3 * math.pi)) * x, masing)
    return {"strain": np.asarray(strains, dtype=float), "G_over_Gmax": modulus,
            "damping_ratio": masing}
