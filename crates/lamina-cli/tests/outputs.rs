//! Outputs never destroy what lamina did not write: the real `lamina` binary writing leaf
//! folders, contact sheets, screenshots and exports over folders and files a user already
//! has.

mod common;
use common::names;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn lamina() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lamina"))
}

fn scratch(name: &str) -> PathBuf {
    common::scratch("outputs", name)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn run(args: &[&str], cwd: &Path) -> Output {
    lamina().args(args).current_dir(cwd).output().unwrap()
}

fn assert_refused(o: &Output, words: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(1), "exit status for:\n{err}");
    assert!(!err.contains("panicked"), "panic:\n{err}");
    for w in words {
        assert!(err.contains(w), "expected '{w}' in:\n{err}");
    }
}

const LEAF_FILES: [&str; 8] = [
    "alpha.png",
    "back.png",
    "bump.png",
    "extinction.png",
    "front.png",
    "leaf.toml",
    "thickness.png",
    "translucency.png",
];

/// A user's folder: a photo and notes.
fn users_folder(root: &Path) -> PathBuf {
    let mine = root.join("leaves/mine");
    std::fs::create_dir_all(&mine).unwrap();
    leaf_photo(&mine.join("photo.png"));
    std::fs::write(mine.join("notes.txt"), "collected 2026-06-01, Grunewald").unwrap();
    mine
}

/// A photograph-like leaf: a green ellipse on a white background.
fn leaf_photo(path: &Path) {
    let img = image::RgbImage::from_fn(96, 128, |x, y| {
        let (u, v) = ((x as f32 - 48.0) / 36.0, (y as f32 - 64.0) / 56.0);
        if u * u + v * v < 1.0 {
            image::Rgb([40, 110 + (x % 7) as u8, 30])
        } else {
            image::Rgb([245, 245, 240])
        }
    });
    img.save(path).unwrap();
}

#[test]
fn leaf_generate_refuses_a_folder_of_user_files_and_keeps_them() {
    let root = scratch("generate-foreign");
    let mine = users_folder(&root);
    let photo = std::fs::read(mine.join("photo.png")).unwrap();
    let o = run(
        &[
            "leaf",
            "generate",
            "--species",
            "beech",
            "-r",
            "96",
            "-o",
            "leaves/mine",
        ],
        &root,
    );
    assert_refused(&o, &["leaves/mine", "photo.png", "notes.txt", "--force"]);
    assert_eq!(names(&mine), ["notes.txt", "photo.png"]);
    assert_eq!(std::fs::read(mine.join("photo.png")).unwrap(), photo);
    assert_eq!(
        names(&root.join("leaves")),
        ["mine"],
        "no temporary folder left"
    );

    // --force writes lamina's eight files and keeps the user's two.
    let o = run(
        &[
            "leaf",
            "generate",
            "-r",
            "96",
            "-o",
            "leaves/mine",
            "--force",
        ],
        &root,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let mut want: Vec<&str> = LEAF_FILES.to_vec();
    want.extend(["notes.txt", "photo.png"]);
    want.sort();
    assert_eq!(names(&mine), want);
    assert_eq!(std::fs::read(mine.join("photo.png")).unwrap(), photo);
    assert_eq!(names(&root.join("leaves")), ["mine"]);
}

#[test]
fn leaf_generate_replaces_its_own_folder() {
    let root = scratch("generate-own");
    let run_gen = |seed: &str| {
        let o = run(
            &["leaf", "generate", "-r", "96", "--seed", seed, "-o", "leaf"],
            &root,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(root.join("leaf/front.png")).unwrap()
    };
    let a = run_gen("1");
    let toml = std::fs::read_to_string(root.join("leaf/leaf.toml")).unwrap();
    assert!(toml.contains("generator = \"lamina "), "{toml}");
    let b = run_gen("2");
    assert_ne!(a, b, "the second seed replaced the first leaf");
    assert_eq!(names(&root.join("leaf")), LEAF_FILES);
    assert_eq!(
        names(&root),
        ["leaf"],
        "no temporary or old folder left beside it"
    );

    // A file added by the user makes it foreign again.
    std::fs::write(root.join("leaf/my-notes.md"), "keep").unwrap();
    let o = run(&["leaf", "generate", "-r", "96", "-o", "leaf"], &root);
    assert_refused(&o, &["my-notes.md"]);
    assert!(root.join("leaf/my-notes.md").exists());

    // A hand-written leaf.toml (no generator) is foreign too.
    let hand = root.join("hand");
    std::fs::create_dir(&hand).unwrap();
    std::fs::write(hand.join("leaf.toml"), "[params]\nthickness_mm = 0.3\n").unwrap();
    let o = run(&["leaf", "generate", "-r", "96", "-o", "hand"], &root);
    assert_refused(&o, &["leaf.toml (not written by lamina)"]);
    assert_eq!(
        std::fs::read_to_string(hand.join("leaf.toml")).unwrap(),
        "[params]\nthickness_mm = 0.3\n"
    );
}

#[test]
fn leaf_prepare_never_deletes_its_input() {
    let root = scratch("prepare-input");
    let mine = users_folder(&root);
    let photo = std::fs::read(mine.join("photo.png")).unwrap();
    let args = [
        "leaf",
        "prepare",
        "--front",
        "leaves/mine/photo.png",
        "-o",
        "leaves/mine",
    ];
    let o = run(&args, &root);
    assert_refused(&o, &["leaves/mine", "photo.png", "--force"]);
    assert_eq!(std::fs::read(mine.join("photo.png")).unwrap(), photo);

    let mut forced = args.to_vec();
    forced.push("--force");
    let o = run(&forced, &root);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(mine.join("photo.png")).unwrap(), photo);
    assert!(mine.join("notes.txt").exists());
    assert!(mine.join("front.png").exists() && mine.join("leaf.toml").exists());

    // An input under an output's own name is refused even with --force.
    let other = root.join("other");
    std::fs::create_dir(&other).unwrap();
    leaf_photo(&other.join("front.png"));
    let before = std::fs::read(other.join("front.png")).unwrap();
    let o = run(
        &[
            "leaf",
            "prepare",
            "--front",
            "other/front.png",
            "-o",
            "other",
            "--force",
        ],
        &root,
    );
    assert_refused(&o, &["other/front.png", "is an input"]);
    assert_eq!(std::fs::read(other.join("front.png")).unwrap(), before);
    assert_eq!(names(&other), ["front.png"]);
    assert_eq!(names(&root), ["leaves", "other"]);
}

#[test]
fn sheets_of_types_lamina_cannot_write_leave_nothing() {
    let root = scratch("sheet-types");
    let o = run(&["leaf", "generate", "-r", "96", "-o", "leaf"], &root);
    assert!(o.status.success(), "{}", stderr(&o));
    for name in ["sheet.bmp", "sheet.tga", "sheet.gif"] {
        let o = run(&["leaf", "sheet", "leaf", "-o", name], &root);
        assert_refused(&o, &[name, "cannot write images of this type"]);
        assert!(!root.join(name).exists(), "{name} left behind");
        // The same check runs before generating when --sheet is given.
        let o = run(
            &[
                "leaf", "generate", "-r", "96", "-o", "leaf2", "--sheet", name,
            ],
            &root,
        );
        assert_refused(&o, &[name]);
        assert!(!root.join("leaf2").exists());
    }
    let o = run(&["leaf", "sheet", "leaf", "-o", "sheet.jpg"], &root);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(names(&root), ["leaf", "sheet.jpg"]);
}

#[test]
fn an_existing_output_folder_in_place_of_an_image_is_kept() {
    let root = scratch("render-over-dir");
    std::fs::write(
        root.join("s.toml"),
        "[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\n[film]\nwidth = 8\nheight = 8\nspp = 1\n\
         [sky]\ntype = \"constant\"\nradiance = 0.5\n",
    )
    .unwrap();
    std::fs::create_dir(root.join("out.png")).unwrap();
    std::fs::write(root.join("out.png/inside.txt"), "mine").unwrap();
    let o = run(&["render", "s.toml", "-o", "out.png", "-q"], &root);
    assert_refused(&o, &["out.png", "folder"]);
    assert!(root.join("out.png/inside.txt").exists());
    assert_eq!(names(&root), ["out.png", "s.toml"]);
}

#[test]
fn demo_export_refuses_a_foreign_folder_and_replaces_its_own() {
    let root = scratch("export");
    let export = |dir: &str, force: bool| {
        let mut args = vec!["demo", "--export-bush", dir, "--size", "32", "--spp", "1"];
        if force {
            args.push("--force");
        }
        run(&args, &root)
    };
    let o = export("bush", false);
    assert!(o.status.success(), "{}", stderr(&o));
    let first = names(&root.join("bush"));
    assert!(first.contains(&"bush.toml".to_string()), "{first:?}");
    let o = export("bush", false);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(names(&root.join("bush")), first);
    assert_eq!(names(&root), ["bush"]);

    let theirs = root.join("theirs");
    std::fs::create_dir(&theirs).unwrap();
    std::fs::write(theirs.join("bush.toml"), "# my own scene\n").unwrap();
    let o = export("theirs", false);
    assert_refused(&o, &["theirs", "bush.toml (not written by lamina)"]);
    assert_eq!(
        std::fs::read_to_string(theirs.join("bush.toml")).unwrap(),
        "# my own scene\n"
    );
    std::fs::write(theirs.join("README"), "keep me").unwrap();
    let o = export("theirs", true);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(theirs.join("README").exists());
    assert!(
        std::fs::read_to_string(theirs.join("bush.toml"))
            .unwrap()
            .starts_with("# The lamina demo bush")
    );
}

/// A tiny scene that renders in a moment.
fn tiny_scene(root: &Path) {
    std::fs::write(
        root.join("s.toml"),
        "[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\n[film]\nwidth = 8\nheight = 8\nspp = 1\n\
         [sky]\ntype = \"constant\"\nradiance = 0.5\n",
    )
    .unwrap();
}

fn is_lamina_file(p: &Path) -> bool {
    lamina_io::file_state(p).unwrap() == lamina_io::FileState::Ours
}

#[test]
fn render_replaces_its_own_images_but_not_a_users_file() {
    let root = scratch("render-files");
    tiny_scene(&root);
    leaf_photo(&root.join("photo.png"));
    let photo = std::fs::read(root.join("photo.png")).unwrap();
    // Another program's EXR (the image crate writes no software attribute).
    image::Rgb32FImage::new(4, 4)
        .save(root.join("theirs.exr"))
        .unwrap();
    let theirs = std::fs::read(root.join("theirs.exr")).unwrap();

    for (out, before) in [("photo.png", &photo), ("theirs.exr", &theirs)] {
        let o = run(&["render", "s.toml", "-o", out, "-q"], &root);
        assert_refused(&o, &[out, "not written by lamina", "--force"]);
        assert_eq!(&std::fs::read(root.join(out)).unwrap(), before, "{out}");
        // The GPU path checks before it looks for a GPU.
        let o = run(&["render", "s.toml", "--gpu", "-o", out, "-q"], &root);
        assert_refused(&o, &[out, "not written by lamina"]);
        assert_eq!(&std::fs::read(root.join(out)).unwrap(), before, "{out}");
    }
    // Refused before the work: with two outputs, the good one is not written either.
    let o = run(
        &["render", "s.toml", "-o", "new.png", "-o", "photo.png", "-q"],
        &root,
    );
    assert_refused(&o, &["photo.png"]);
    assert_eq!(names(&root), ["photo.png", "s.toml", "theirs.exr"]);

    // lamina's own images, PNG and EXR, carry the mark and are replaced without --force.
    for _ in 0..2 {
        let o = run(
            &["render", "s.toml", "-o", "r.png", "-o", "r.exr", "-q"],
            &root,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(is_lamina_file(&root.join("r.png")));
        assert!(is_lamina_file(&root.join("r.exr")));
    }
    assert_eq!(image::open(root.join("r.exr")).unwrap().width(), 8);

    // --force replaces the user's file, with a lamina image (which later runs may replace).
    let o = run(
        &["render", "s.toml", "-o", "photo.png", "--force", "-q"],
        &root,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(image::open(root.join("photo.png")).unwrap().width(), 8);
    assert!(is_lamina_file(&root.join("photo.png")));
    let o = run(&["render", "s.toml", "-o", "photo.png", "-q"], &root);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        names(&root),
        ["photo.png", "r.exr", "r.png", "s.toml", "theirs.exr"]
    );
}

#[test]
fn sheets_glb_screenshots_and_the_demo_refuse_a_users_file() {
    let root = scratch("other-files");
    leaf_photo(&root.join("photo.jpg"));
    std::fs::write(
        root.join("tree.glb"),
        "not lamina's: a model from elsewhere",
    )
    .unwrap();
    let o = run(&["leaf", "generate", "-r", "64", "-o", "leaf"], &root);
    assert!(o.status.success(), "{}", stderr(&o));
    let kept = |name: &str, before: &[u8]| {
        assert_eq!(std::fs::read(root.join(name)).unwrap(), before, "{name}");
    };
    let photo = std::fs::read(root.join("photo.jpg")).unwrap();
    let model = std::fs::read(root.join("tree.glb")).unwrap();

    // Contact sheets: -o, and --sheet of generate (checked before generating).
    let o = run(&["leaf", "sheet", "leaf", "-o", "photo.jpg"], &root);
    assert_refused(&o, &["photo.jpg", "not written by lamina"]);
    let o = run(
        &[
            "leaf",
            "generate",
            "-r",
            "64",
            "-o",
            "leaf2",
            "--sheet",
            "photo.jpg",
        ],
        &root,
    );
    assert_refused(&o, &["photo.jpg"]);
    assert!(!root.join("leaf2").exists());
    kept("photo.jpg", &photo);
    // A leaf map is the sheet's input: never overwritten, not even with --force.
    let front = std::fs::read(root.join("leaf/front.png")).unwrap();
    let o = run(
        &["leaf", "sheet", "leaf", "-o", "leaf/front.png", "--force"],
        &root,
    );
    assert_refused(&o, &["leaf/front.png", "inputs"]);
    kept("leaf/front.png", &front);
    for _ in 0..2 {
        let o = run(
            &["leaf", "sheet", "leaf", "-o", "sheet.png", "--tile", "32"],
            &root,
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert!(is_lamina_file(&root.join("sheet.png")));

    // Plants: refused before growing.
    let plant = |out: &str, force: bool| {
        let mut a = vec![
            "plant",
            "generate",
            "-n",
            "50",
            "--variants",
            "1",
            "--leaf-resolution",
            "32",
            "-o",
            out,
        ];
        if force {
            a.push("--force");
        }
        run(&a, &root)
    };
    let o = plant("tree.glb", false);
    assert_refused(&o, &["tree.glb", "not written by lamina"]);
    assert!(!stderr(&o).contains("leaves in"), "grew the plant first");
    kept("tree.glb", &model);
    for _ in 0..2 {
        let o = plant("bush.glb", false);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert!(is_lamina_file(&root.join("bush.glb")));

    // Screenshots and the demo image: refused before a window or a render.
    let o = run(
        &[
            "view",
            "demo:front",
            "--frames",
            "1",
            "--screenshot",
            "photo.jpg",
        ],
        &root,
    );
    assert_refused(&o, &["photo.jpg", "not written by lamina"]);
    kept("photo.jpg", &photo);
    leaf_photo(&root.join("photo.png"));
    let png = std::fs::read(root.join("photo.png")).unwrap();
    let o = run(
        &["demo", "--size", "16", "--spp", "1", "-o", "photo.png"],
        &root,
    );
    assert_refused(&o, &["photo.png", "not written by lamina"]);
    assert!(!stderr(&o).contains("spp"), "rendered first");
    kept("photo.png", &png);

    // --force replaces the user's file.
    let o = plant("tree.glb", true);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(is_lamina_file(&root.join("tree.glb")));
    let o = run(
        &[
            "leaf",
            "sheet",
            "leaf",
            "-o",
            "photo.jpg",
            "--force",
            "--tile",
            "32",
        ],
        &root,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(is_lamina_file(&root.join("photo.jpg")));
    assert_eq!(
        names(&root),
        [
            "bush.glb",
            "leaf",
            "photo.jpg",
            "photo.png",
            "sheet.png",
            "tree.glb"
        ]
    );
}

/// An error whose message already ends with its cause prints the cause once.
#[test]
fn an_os_error_is_printed_once() {
    let root = scratch("cause-once");
    tiny_scene(&root);
    // /proc takes no new files: the write fails with an OS error.
    let o = run(&["render", "s.toml", "-o", "/proc/lamina-test.png"], &root);
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert_eq!(e.matches("os error").count(), 1, "{e}");
    // A leaf folder that is not there.
    let o = run(&["leaf", "albedo", "no-such-leaf", "-o", "a.csv"], &root);
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert_eq!(e.matches("os error").count(), 1, "{e}");
}
