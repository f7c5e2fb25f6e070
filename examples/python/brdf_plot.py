"""Plot a leaf's BRDF and BTDF in the plane of incidence, and its R and T spectra.

    python examples/python/brdf_plot.py [-o brdf.png]   (needs matplotlib)

Left: f·cos for light at 30 degrees on the adaxial side, over outgoing angles in the
plane of incidence (reflection above the leaf, transmission below), for a maple leaf
(RGB) evaluated with the renderer's own BSDF over NumPy arrays. Right: PROSPECT-D's
reflectance and transmittance of a green leaf, and the pigment leaf's R and T integrated
from its BSDF at 8 degrees (what ``lamina leaf albedo`` prints).
"""

import argparse

import numpy as np

import lamina


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default="brdf.png")
    args = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    leaf = lamina.Leaf.species("maple")
    th_i = np.radians(30)
    wi = np.array([-np.sin(th_i), 0.0, np.cos(th_i)])  # toward the light
    th = np.radians(np.linspace(-89, 89, 357))
    up = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], axis=1)
    down = up * np.array([1, 1, -1])
    uv = [0.3, 0.55]  # a texel between the veins
    fr = leaf.eval(up, wi, uv=uv)  # f·cos(θo) toward the viewer above
    ft = leaf.eval(down, wi, uv=uv)

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    for k, c in enumerate("rgb"):
        a.plot(np.degrees(th), fr[:, k], c, label=f"reflection ({c.upper()})")
        a.plot(np.degrees(th), ft[:, k], c + "--", label=f"transmission ({c.upper()})")
    a.set_xlabel("outgoing angle from the normal, in the plane of incidence (deg)")
    a.set_ylabel("f · cos θ  (1/sr)")
    a.set_title("maple leaf, light at 30° on the upper side")
    a.legend(fontsize=7)

    wl, r, t = lamina.prospect(cab=40, car=8, cw=0.012, cm=0.009)
    pig = lamina.Leaf.from_dict({"pigments": {"cab": 40, "car": 8, "cw": 0.012, "cm": 0.009}})
    nm = np.arange(400, 2501, 50, dtype=float)
    br, bt = pig.albedo(wavelengths=nm)
    b.plot(wl, r, "g", label="PROSPECT-D R")
    b.plot(wl, 1 - t, "b", label="PROSPECT-D 1 - T")
    b.plot(nm, br, "go", ms=3, label="lamina leaf R (from its BSDF)")
    b.plot(nm, 1 - bt, "bo", ms=3, label="lamina leaf 1 - T")
    b.set_xlabel("wavelength (nm)")
    b.set_ylim(0, 1)
    b.set_title("green leaf, Cab 40 µg/cm², 8° incidence")
    b.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(args.output, dpi=110)
    print(f"wrote {args.output}; RMSE R {np.sqrt(np.mean((br - np.interp(nm, wl, r))**2)):.4f}")


if __name__ == "__main__":
    main()
