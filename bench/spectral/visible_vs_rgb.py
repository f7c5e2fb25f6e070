#!/usr/bin/env python3
"""The RGB render and the `visible` render of the same scene, compared in CIEDE2000 (issue 14:
they must agree within a mean of 2).

For each scene it renders `[film] spectral = "rgb"` and `"visible"` at the same spp and seed,
averages both images over blocks of 8x8 pixels (so that the comparison is of colour, not of
Monte Carlo noise), takes the 99th percentile of the RGB blocks' luminance as CIELAB's white
(Y = 1, D65; a percentile, so that a block holding the sun's disk does not make every other
block black; blocks brighter than 10 times that white, the sun's disk, are left out and
counted), and prints the mean, the 95th percentile and the largest CIEDE2000 over blocks, computed by
colour-science (an implementation independent of lamina's). It also writes both PNGs (the
film's own tone mapping) to look at.

    python3 bench/spectral/visible_vs_rgb.py [--lamina target/release/lamina] [--spp 64]

Needs `pip install mitsuba colour-science` (Mitsuba only to read the EXRs).
"""

import argparse
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import common  # noqa: E402

SCENES = {
    "leaf_cards": "examples/leaf_cards.toml",
    "pigment": "examples/pigment_leaves.toml",
    "fig5": "examples/gallery/fig5_bush_backlit.toml",
    "bush": None,  # the demo bush, exported by `lamina demo --export-bush`
}


def load(path):
    import mitsuba as mi
    b = mi.Bitmap(str(path)).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32,
                                     srgb_gamma=False)
    return np.array(b, dtype=np.float64)


def blocks(img, k=8):
    h, w = (img.shape[0] // k) * k, (img.shape[1] // k) * k
    return img[:h, :w].reshape(h // k, k, w // k, k, 3).mean(axis=(1, 3)).reshape(-1, 3)


def delta_e(rgb_a, rgb_b, white_y):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import colour
    cs = colour.RGB_COLOURSPACES["sRGB"]
    wp = cs.whitepoint

    def lab(rgb):
        xyz = colour.RGB_to_XYZ(rgb / white_y, cs, apply_cctf_decoding=False)
        return colour.XYZ_to_Lab(xyz, wp)
    return colour.delta_E(lab(rgb_a), lab(rgb_b), method="CIE 2000")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lamina")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--out", default=str(common.DEFAULT_OUT / "visible_vs_rgb"))
    args = ap.parse_args()
    lamina = common.lamina_binary(args.lamina)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print(f"{args.spp} spp, seed 1, {args.threads} threads; CIEDE2000 over 8x8-pixel blocks, "
          f"white = the 99th percentile of the RGB blocks' luminance")
    print("| scene | blocks | left out (> 10x white) | mean ΔE00 | 95th percentile | largest | RGB s | visible s |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.scenes.split(","):
        scene = SCENES[name]
        if scene is None:
            scene = out / "bush" / "bush.toml"
            if not scene.exists():
                subprocess.run([str(lamina), "demo", "--export-bush", str(scene.parent)],
                               check=True, capture_output=True)
        secs = {}
        imgs = {}
        for mode in ("rgb", "visible"):
            exr, png = out / f"{name}_{mode}.exr", out / f"{name}_{mode}.png"
            cmd = [str(lamina), "render", str(scene), "--spp", str(args.spp), "--seed", "1",
                   "--threads", str(args.threads), "--quiet", "--force", "-o", str(exr), "-o",
                   str(png), "--set", f'film.spectral="{mode}"']
            r = subprocess.run(cmd, capture_output=True, text=True)
            if r.returncode != 0:
                sys.exit(f"lamina failed:\n{' '.join(cmd)}\n{r.stderr}")
            m = common.SUMMARY_RE.search(r.stderr)
            secs[mode] = float(m.group(4)) if m else float("nan")
            imgs[mode] = blocks(load(exr))
        a, b = imgs["rgb"], imgs["visible"]
        y = a @ np.array([0.2126, 0.7152, 0.0722])
        white = float(np.percentile(y, 99))
        keep = y <= 10.0 * white
        d = delta_e(b[keep], a[keep], white)
        print(f"| {name} | {len(d)} | {int((~keep).sum())} | {d.mean():.2f} | {np.percentile(d, 95):.2f} | {d.max():.2f} "
              f"| {secs['rgb']:.1f} | {secs['visible']:.1f} |", flush=True)


if __name__ == "__main__":
    main()
