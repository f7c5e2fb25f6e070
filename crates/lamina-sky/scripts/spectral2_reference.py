#!/usr/bin/env python3
"""Reference values for lamina-sky's SPCTRAL2 tests (src/spectral2.rs), from pvlib.

pvlib's ``pvlib.spectrum.spectrl2`` implements the same model (Bird & Riordan, SERI/TR-215-2436,
1984; J. Climate Appl. Meteor. 25, 1986) the way NREL's C code ``spectrl2_2.c`` does, which
differs from the report's printed equations in four places (pvlib's docstring lists them). The
Rust module computes both: ``Formulation::Pvlib`` must match these numbers to 1e-4 relative,
``Formulation::Paper`` (the default) is compared to them with the looser, per-effect bars its
tests document.

Every case is a horizontal surface: ``surface_tilt = 0`` and ``aoi = apparent_zenith``, so
``poa_direct`` is the direct horizontal irradiance and ``poa_sky_diffuse`` the diffuse horizontal
(``dhi``; the script checks that they agree). The relative air mass is
``pvlib.atmosphere.get_relative_airmass(zenith, model)``, Kasten & Young 1989 unless a case names
Kasten 1966 (the report's eq. 2-5). Pressure is given in hPa here and passed to pvlib in Pa.

Run: ``python3 crates/lamina-sky/scripts/spectral2_reference.py`` (pvlib 0.16.1 was used for the
numbers in the tests). It prints a human-readable table, then the Rust literals pasted into
``pvlib_cases()`` in src/spectral2.rs.
"""

import sys

import numpy as np
import pvlib
from pvlib.atmosphere import get_relative_airmass
from pvlib.spectrum import spectrl2

# The wavelengths (nm) the tests compare at: both ends of the ozone-absorbed UV, the Cs
# boundary (450 nm), the visible, the O2 A band (mixed gas), water bands at 937 and 2198 nm,
# and a near-infrared window.
WAVELENGTHS = [300.0, 400.0, 450.0, 550.0, 762.5, 937.0, 1240.0, 2198.0]

DEFAULTS = dict(
    pressure=1013.25,  # hPa
    precipitable_water=1.42,  # cm
    ozone=0.344,  # atm-cm
    aod500=0.1,
    alpha=1.14,
    asymmetry=0.65,
    ssa400=0.945,
    ssa_variation=0.095,
    ground_albedo=0.2,
    air_mass="kastenyoung1989",
)

CASES = [
    dict(name="zenith 0, defaults, 21 June", zenith=0.0, day_of_year=172),
    dict(
        name="zenith 30, hazy and humid, 1 January",
        zenith=30.0,
        day_of_year=1,
        precipitable_water=3.5,
        aod500=0.3,
        alpha=1.3,
    ),
    dict(
        name="zenith 60, clean and dry high site, 10 April",
        zenith=60.0,
        day_of_year=100,
        pressure=850.0,
        precipitable_water=0.5,
        ozone=0.30,
        aod500=0.05,
        alpha=0.9,
        asymmetry=0.7,
        ssa400=0.9,
        ssa_variation=0.05,
        ground_albedo=0.35,
    ),
    dict(name="zenith 80, defaults, 27 October", zenith=80.0, day_of_year=300),
    dict(
        name="zenith 60, defaults, Kasten 1966 air mass, 3 July",
        zenith=60.0,
        day_of_year=184,
        air_mass="kasten1966",
    ),
]


def trapezoid(y, x):
    """The integral of the piecewise-linear interpolant of (x, y)."""
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x)))


def run(case):
    c = dict(DEFAULTS, **case)
    zenith = np.array([c["zenith"]])
    air_mass = get_relative_airmass(zenith, model=c["air_mass"])
    out = spectrl2(
        apparent_zenith=zenith,
        aoi=zenith,
        surface_tilt=np.array([0.0]),
        ground_albedo=np.array([c["ground_albedo"]]),
        surface_pressure=np.array([c["pressure"] * 100.0]),
        relative_airmass=air_mass,
        precipitable_water=np.array([c["precipitable_water"]]),
        ozone=np.array([c["ozone"]]),
        aerosol_turbidity_500nm=np.array([c["aod500"]]),
        dayofyear=np.array([c["day_of_year"]]),
        scattering_albedo_400nm=np.array([c["ssa400"]]),
        alpha=np.array([c["alpha"]]),
        wavelength_variation_factor=np.array([c["ssa_variation"]]),
        aerosol_asymmetry_factor=np.array([c["asymmetry"]]),
    )
    wl = out["wavelength"]
    dni = out["dni"][:, 0]
    direct_h = out["poa_direct"][:, 0]
    diffuse_h = out["poa_sky_diffuse"][:, 0]
    # poa_sky_diffuse on a horizontal plane is the model's diffuse horizontal irradiance.
    assert np.allclose(diffuse_h, out["dhi"][:, 0], rtol=1e-12, atol=0)
    assert np.allclose(direct_h, dni * np.cos(np.radians(c["zenith"])), rtol=1e-12, atol=1e-300)
    assert np.all(out["poa_ground_diffuse"] == 0)
    idx = [int(np.flatnonzero(wl == w)[0]) for w in WAVELENGTHS]
    return dict(
        c=c,
        air_mass=float(air_mass[0]),
        dni=dni[idx],
        direct_h=direct_h[idx],
        diffuse_h=diffuse_h[idx],
        integrals=[trapezoid(v, wl) for v in (dni, direct_h, diffuse_h)],
    )


def fmt(v):
    return f"{v:.10e}"


def main():
    print(f"pvlib {pvlib.__version__}, numpy {np.__version__}", file=sys.stderr)
    results = [run(case) for case in CASES]
    for r in results:
        c = r["c"]
        print(f"# {c['name']}: relative air mass {r['air_mass']:.10f} ({c['air_mass']})")
        print(f"#   {'nm':>7} {'direct normal':>16} {'direct horiz.':>16} {'diffuse horiz.':>16}")
        for w, a, b, d in zip(WAVELENGTHS, r["dni"], r["direct_h"], r["diffuse_h"]):
            print(f"#   {w:7.1f} {a:16.9e} {b:16.9e} {d:16.9e}")
        i = r["integrals"]
        print(f"#   300-4000 nm, W/m²: {i[0]:.6f} {i[1]:.6f} {i[2]:.6f}")
    print()
    print("// Generated by crates/lamina-sky/scripts/spectral2_reference.py")
    print(f"// (pvlib {pvlib.__version__}).")
    for r in results:
        c = r["c"]
        model = {"kastenyoung1989": "KastenYoung1989", "kasten1966": "Kasten1966"}[c["air_mass"]]
        print("PvlibCase {")
        print(f'    name: "{c["name"]}",')
        print(f"    zenith: {float(c['zenith'])!r},")
        print(f"    day_of_year: {c['day_of_year']},")
        for key in (
            "pressure",
            "precipitable_water",
            "ozone",
            "aod500",
            "alpha",
            "asymmetry",
            "ssa400",
            "ssa_variation",
            "ground_albedo",
        ):
            print(f"    {key}: {float(c[key])!r},")
        print(f"    air_mass: AirMass::{model},")
        print(f"    relative_air_mass: {fmt(r['air_mass'])},")
        for key in ("dni", "direct_h", "diffuse_h"):
            values = ", ".join(fmt(v) for v in r[key])
            print(f"    {key}: [{values}],")
        print(f"    integrals: [{', '.join(fmt(v) for v in r['integrals'])}],")
        print("},")


if __name__ == "__main__":
    main()
