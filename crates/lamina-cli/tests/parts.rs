//! `lamina render --part K/N | --crop` and `lamina merge` through the real binary: merged
//! parts equal the single render bit for bit, and parts that do not belong together,
//! overlap, are missing or are corrupt give clear errors and write nothing.

mod common;

use common::{SCENE, assert_same, channels, fails, image_channels, lamina, ok, scratch};

#[test]
fn parts_and_crops_merge_to_the_single_render_bit_for_bit() {
    let d = scratch("parts", "exact");
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    let common = ["--seed", "9", "--quiet"];
    let run = |extra: &[&str]| {
        let mut a = vec!["render", "s.toml"];
        a.extend_from_slice(&common);
        a.extend_from_slice(extra);
        ok(&lamina(&a, &d))
    };
    run(&["-o", "whole.exr", "-o", "whole.png"]);
    // Four parts by samples.
    for k in 0..4 {
        run(&["--part", &format!("{k}/4"), "-o", &format!("p{k}.exr")]);
    }
    let e = ok(&lamina(
        &[
            "merge", "p0.exr", "p1.exr", "p2.exr", "p3.exr", "-o", "m.exr", "-o", "m.png",
        ],
        &d,
    ));
    assert!(
        e.contains("merged 4 parts") && e.contains("complete"),
        "{e}"
    );
    let whole = image_channels(&d.join("whole.exr"));
    assert_eq!(whole.len(), 3);
    assert_same(&d.join("m.exr"), &d.join("whole.exr"));
    assert_eq!(
        std::fs::read(d.join("m.png")).unwrap(),
        std::fs::read(d.join("whole.png")).unwrap()
    );
    // Tiles (crossing the 32-pixel render tiles) times two sample parts, any order.
    let mut tiles = Vec::new();
    for (x0, x1) in [(0, 17), (17, 40)] {
        for (y0, y1) in [(0, 11), (11, 30)] {
            for k in 0..2 {
                let name = format!("t{x0}_{y0}_{k}.exr");
                run(&[
                    "--crop",
                    &format!("{x0},{y0},{x1},{y1}"),
                    "--part",
                    &format!("{k}/2"),
                    "-o",
                    &name,
                ]);
                tiles.push(name);
            }
        }
    }
    tiles.reverse();
    let mut a = vec!["merge"];
    a.extend(tiles.iter().map(String::as_str));
    a.extend(["-o", "t.exr"]);
    ok(&lamina(&a, &d));
    assert_same(&d.join("t.exr"), &d.join("whole.exr"));
    // A crop's own pixels (the part file's data window) equal the whole image's.
    let part = channels(&d.join("t17_11_0.exr"));
    assert_eq!(part["R"].len(), 23 * 19);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn spectral_band_parts_merge_to_the_band_render() {
    let d = scratch("parts", "bands");
    let scene = SCENE.replace(
        "spp = 12\n",
        "spp = 4\nbands = [{ name = \"red\", center = 665, width = 30 }, { name = \"green\", \
         center = 560, width = 30 }, { name = \"blue\", center = 490, width = 60 }, { name = \
         \"nir\", center = 842, width = 100 }]\nfalse_color = [\"nir\", \"red\", \"green\"]\n",
    );
    std::fs::write(d.join("b.toml"), scene).unwrap();
    ok(&lamina(&["render", "b.toml", "-q", "-o", "whole.exr"], &d));
    for k in 0..2 {
        ok(&lamina(
            &[
                "render",
                "b.toml",
                "-q",
                "--part",
                &format!("{k}/2"),
                "-o",
                &format!("p{k}.exr"),
            ],
            &d,
        ));
    }
    ok(&lamina(
        &["merge", "p0.exr", "p1.exr", "-o", "m.exr", "-o", "m.png"],
        &d,
    ));
    let whole = image_channels(&d.join("whole.exr"));
    assert_eq!(
        whole.keys().collect::<Vec<_>>(),
        ["blue", "green", "nir", "red"]
    );
    assert_same(&d.join("m.exr"), &d.join("whole.exr"));
    assert!(d.join("m.png").is_file());
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn bad_parts_and_flags_are_clear_errors_and_write_nothing() {
    let d = scratch("parts", "bad");
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    let render = |extra: &[&str]| {
        let mut a = vec!["render", "s.toml", "-q"];
        if !extra.contains(&"--spp") {
            a.extend(["--spp", "4"]);
        }
        a.extend_from_slice(extra);
        lamina(&a, &d)
    };
    fails(
        &render(&["--part", "4/4", "-o", "x.exr"]),
        &["--part", "K must be below N"],
    );
    fails(
        &render(&["--part", "a/4", "-o", "x.exr"]),
        &["--part", "'a'"],
    );
    fails(
        &render(&["--part", "1/8", "-o", "x.exr"]),
        &["--part 1/8", "at most 4 parts"],
    );
    fails(
        &render(&["--crop", "0,0,41,10", "-o", "x.exr"]),
        &["--crop", "40x30"],
    );
    fails(
        &render(&["--crop", "5,5,5,9", "-o", "x.exr"]),
        &["--crop", "empty"],
    );
    fails(
        &render(&["--crop", "1,2,3", "-o", "x.exr"]),
        &["--crop", "X0,Y0,X1,Y1"],
    );
    fails(
        &render(&["--part", "0/2", "-o", "x.png"]),
        &["name an .exr output"],
    );
    fails(
        &render(&["--part", "0/2", "--gpu", "-o", "x.exr"]),
        &["--gpu"],
    );
    assert!(!d.join("x.exr").exists() && !d.join("x.png").exists());

    ok(&render(&["--part", "0/2", "-o", "a0.exr"]));
    ok(&render(&["--part", "1/2", "-o", "a1.exr"]));
    ok(&render(&["--part", "1/2", "--seed", "3", "-o", "seed.exr"]));
    ok(&render(&["--part", "1/2", "--spp", "6", "-o", "spp.exr"]));
    std::fs::write(
        d.join("t.toml"),
        SCENE.replace("irradiance = 3", "irradiance = 4"),
    )
    .unwrap();
    ok(&lamina(
        &[
            "render",
            "t.toml",
            "-q",
            "--spp",
            "4",
            "--part",
            "1/2",
            "-o",
            "other.exr",
        ],
        &d,
    ));
    ok(&render(&["--part", "0/4", "-o", "q0.exr"]));
    ok(&render(&["-o", "plain.exr"]));
    let merge = |args: &[&str]| {
        let mut a = vec!["merge"];
        a.extend_from_slice(args);
        lamina(&a, &d)
    };
    fails(
        &merge(&["a0.exr", "seed.exr", "-o", "m.exr"]),
        &["'seed.exr'", "seed is 3, not 0"],
    );
    fails(
        &merge(&["a0.exr", "spp.exr", "-o", "m.exr"]),
        &["'spp.exr'", "samples per pixel"],
    );
    fails(
        &merge(&["a0.exr", "other.exr", "-o", "m.exr"]),
        &["'other.exr'", "scene hash"],
    );
    fails(
        &merge(&["a0.exr", "q0.exr", "a1.exr", "-o", "m.exr"]),
        &["overlap", "samples 0..1"],
    );
    fails(
        &merge(&["a0.exr", "a0.exr", "a1.exr", "-o", "m.exr"]),
        &["given twice"],
    );
    fails(
        &merge(&["a0.exr", "-o", "m.exr"]),
        &["samples 2..4 (--part 1/2)", "--allow-missing"],
    );
    fails(
        &merge(&["a0.exr", "plain.exr", "-o", "m.exr"]),
        &["'plain.exr'", "lamina.part"],
    );
    let bytes = std::fs::read(d.join("a1.exr")).unwrap();
    std::fs::write(d.join("cut.exr"), &bytes[..bytes.len() * 2 / 3]).unwrap();
    fails(
        &merge(&["a0.exr", "cut.exr", "-o", "m.exr"]),
        &["'cut.exr'"],
    );
    let o = merge(&["a0.exr", "gone.exr", "-o", "m.exr"]);
    fails(&o, &["cannot read part 'gone.exr'"]);
    // The cause is said once, not repeated by the error chain.
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(e.matches("No such file").count(), 1, "{e}");
    assert!(!d.join("m.exr").exists());
    // A user's file is kept; the inputs are never outputs.
    std::fs::write(d.join("mine.exr"), "my notes").unwrap();
    fails(
        &merge(&["a0.exr", "a1.exr", "-o", "mine.exr"]),
        &["mine.exr"],
    );
    assert_eq!(
        std::fs::read_to_string(d.join("mine.exr")).unwrap(),
        "my notes"
    );
    fails(&merge(&["a0.exr", "a1.exr", "-o", "a1.exr"]), &["a1.exr"]);
    // With --allow-missing the best image is written and says what it holds.
    let e = ok(&merge(&["a0.exr", "--allow-missing", "-o", "half.exr"]));
    assert!(
        e.contains("2-2 of 4 samples") && e.contains("INCOMPLETE"),
        "{e}"
    );
    let meta = exr::meta::MetaData::read_from_file(d.join("half.exr"), false).unwrap();
    let text = format!("{:?}", meta.headers[0].own_attributes.other);
    assert!(text.contains(r#""complete":false"#), "{text}");
    std::fs::remove_dir_all(&d).unwrap();
}
