#!/usr/bin/env python3
"""lamina's clear sky (`lamina sky`: Preetham 1999 scaled to SPCTRAL2's diffuse irradiance)
against Mitsuba 3's `sunsky` emitter (Hosek & Wilkie 2012 sky, sun_scale 0) for the same
sun, turbidity 3, ground albedo 0.2.

Usage: python3 bench/spectral/sunsky_compare.py [path/to/lamina]   (pip install mitsuba)

Prints, per sun elevation, linear Rec.709 radiance (W m^-2 sr^-1) at a few directions and the
sky's horizontal irradiance (luminance-weighted Y), both renderers side by side.
"""
import os
import subprocess
import sys
import tempfile

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
LAMINA = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
    os.path.dirname(__file__), "..", "..", "target", "release", "lamina")

# Paris, 21 June 2024: sun elevations about 64, 31 and 9 degrees.
TIMES = ["2024-06-21T14:00:00+02:00", "2024-06-21T18:15:00+02:00", "2024-06-21T20:30:00+02:00"]
W = 512


def lamina_sky(time, out):
    r = subprocess.run([LAMINA, "sky", "--latitude", "48.8566", "--longitude", "2.3522",
                        "--time", time, "--turbidity", "3", "--width", str(W), "-o", out,
                        "--force"], capture_output=True, text=True, check=True)
    line = [l for l in r.stderr.splitlines() if "direction toward the sun" in l][0]
    d = np.array([float(x) for x in line.split("[")[1].split("]")[0].split(",")])
    elev = float([l for l in r.stderr.splitlines() if l.startswith("sun at")][0]
                 .split("elevation ")[1].rstrip("°"))
    return d, elev


def to_mitsuba(d):
    # lamina-sky: x east, y up, z south. Mitsuba's sunsky: z up. Keep right-handedness.
    return np.array([d[0], -d[2], d[1]])


def lookup(img, d):
    """Radiance of lamina's lat-long image in world direction d (x east, y up, z south)."""
    h, w, _ = img.shape
    phi = np.arctan2(d[0], -d[2])
    theta = np.arctan2(np.hypot(d[0], d[2]), d[1])
    i = min(int((phi + np.pi) / (2 * np.pi) * w), w - 1)
    j = min(int(theta / np.pi * h), h - 1)
    return img[j, i]


def rot_y(d, deg):
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    return np.array([c * d[0] + s * d[2], d[1], -s * d[0] + c * d[2]])


def direction(az_from_sun, elevation, sun):
    """A direction at `elevation` degrees, `az_from_sun` degrees in azimuth from the sun."""
    sun_az = np.arctan2(sun[0], -sun[2])
    az = sun_az + np.radians(az_from_sun)
    e = np.radians(elevation)
    return np.array([np.cos(e) * np.sin(az), np.sin(e), -np.cos(e) * np.cos(az)])


print(f"{'sun elev':>8} {'direction':<28} {'lamina (Preetham + SPCTRAL2)':<32} {'Mitsuba sunsky (Hosek-Wilkie)':<32}")
for t in TIMES:
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "sky.exr")
        sun, elev = lamina_sky(t, out)
        img = np.array(mi.Bitmap(out))[..., :3]
    em = mi.load_dict({"type": "sunsky", "sun_direction": to_mitsuba(sun).tolist(),
                       "turbidity": 3.0, "albedo": 0.2, "sun_scale": 0.0})

    def mts(d):
        si = mi.SurfaceInteraction3f()
        v = to_mitsuba(d)
        si.wi = mi.Vector3f(*(-v))
        return np.array(em.eval(si))

    rows = [("zenith", np.array([0.0, 1.0, 0.0])),
            ("10 deg from the sun", direction(0, min(elev + 10, 89), sun)),
            ("90 deg azimuth, 30 deg up", direction(90, 30, sun)),
            ("opposite, 30 deg up", direction(180, 30, sun)),
            ("horizon, 90 deg azimuth", direction(90, 2, sun))]
    for name, d in rows:
        a, b = lookup(img, d), mts(d)
        fa = "(" + ", ".join(f"{x:.4f}" for x in a) + ")"
        fb = "(" + ", ".join(f"{x:.4f}" for x in b) + ")"
        print(f"{elev:8.1f} {name:<28} {fa:<32} {fb:<32}")
    # Horizontal irradiance of the sky, Y = 0.2126 R + 0.7152 G + 0.0722 B.
    n = 128
    e_l = e_m = 0.0
    for j in range(n):
        th = (j + 0.5) / n * np.pi / 2
        for k in range(2 * n):
            ph = (k + 0.5) / (2 * n) * 2 * np.pi
            d = np.array([np.sin(th) * np.sin(ph), np.cos(th), -np.sin(th) * np.cos(ph)])
            w = np.cos(th) * np.sin(th) * (np.pi / 2 / n) * (2 * np.pi / (2 * n))
            y = np.array([0.2126, 0.7152, 0.0722])
            e_l += w * lookup(img, d) @ y
            e_m += w * mts(d) @ y
    print(f"{elev:8.1f} {'sky irradiance Y, W/m2':<28} {e_l:<32.2f} {e_m:<32.2f}")
