"""Render one maple leaf lit from the front and from behind, side by side.

    python examples/python/leaf_pair.py [-o leaf_pair.png] [--spp 64]

The scene is a dict (the keys of a scene file); the second view only moves the sun behind
the leaf and re-renders, without reloading anything. Writes a PNG through lamina (exposure
and tone map of the scene's film).
"""

import argparse

import numpy as np

import lamina

SCENE = {
    "camera": {"position": [0.0, 0.0, 0.42], "look_at": [0.0, 0.0, 0.0], "fov": 40},
    "film": {"width": 320, "height": 320, "spp": 64, "exposure": -0.5},
    "sky": {"type": "constant", "radiance": [0.05, 0.07, 0.1]},
    "light": [{"type": "sun", "direction": [0.3, 0.4, 1.0], "irradiance": 3.0}],
    "material": [{"name": "maple", "type": "leaf", "species": "maple"}],
    "object": [
        {
            "type": "quad",
            "material": "maple",
            "corner": [-0.14, -0.14, 0.0],
            "edge_u": [0.28, 0.0, 0.0],
            "edge_v": [0.0, 0.28, 0.0],
        }
    ],
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default="leaf_pair.png")
    ap.add_argument("--spp", type=int, default=64)
    args = ap.parse_args()

    scene = lamina.Scene.from_dict(SCENE)
    front = lamina.render(scene, spp=args.spp, progress=True)
    scene.sun_direction = [0.3, 0.4, -1.0]  # behind the leaf: it glows by transmission
    back = lamina.render(scene, spp=args.spp, progress=True)
    gap = np.zeros((front.shape[0], 8, 3), np.float32)
    pair = np.concatenate([front, gap, back], axis=1)
    print(f"front-lit mean {front.mean(axis=(0, 1))}, back-lit mean {back.mean(axis=(0, 1))}")
    lamina.write_image(args.output, pair, scene)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
