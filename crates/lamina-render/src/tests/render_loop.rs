//! The render loop: determinism across thread counts, time limits and cancellation, and
//! option errors.

use super::scenes::*;
use crate::{RenderOptions, render};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// (d) Same seed → bit-identical image with 1 and 2 threads; another seed differs.
#[test]
fn deterministic_across_thread_counts() {
    let scene = small_canopy_scene();
    let a = render(&scene, &opts(8, 1)).unwrap();
    let b = render(&scene, &opts(8, 2)).unwrap();
    assert!(a.image.pixels.iter().all(|p| p.is_finite()));
    assert_eq!(a.image, b.image);
    assert_eq!(a.stats.rays, b.stats.rays);
    let c = render(
        &scene,
        &RenderOptions {
            seed: 8,
            ..opts(8, 2)
        },
    )
    .unwrap();
    assert_ne!(a.image, c.image);
    assert!(a.image.mean().max_element() > 0.0);
}

/// (e) A time limit or the cancel flag returns a valid image of the completed passes.
#[test]
fn time_limit_and_cancel_return_valid_images() {
    let scene = small_canopy_scene();
    let out = render(
        &scene,
        &RenderOptions {
            time_limit: Some(Duration::from_millis(300)),
            ..opts(1_000_000, 2)
        },
    )
    .unwrap();
    assert!(out.stats.stopped_early);
    assert!(out.stats.spp_done >= 1 && out.stats.spp_done < 1_000_000);
    assert!(out.stats.elapsed < Duration::from_secs(5));
    assert!(out.image.pixels.iter().all(|p| p.is_finite()));
    assert!(out.image.mean().max_element() > 0.0);

    let cancel = Arc::new(AtomicBool::new(false));
    let flag = cancel.clone();
    let out = render(
        &scene,
        &RenderOptions {
            cancel: Some(cancel),
            progress: Some(Arc::new(move |p| {
                if p.passes_done == 2 {
                    flag.store(true, Ordering::Relaxed);
                }
            })),
            progressive: true,
            ..opts(64, 2)
        },
    )
    .unwrap();
    assert!(out.stats.stopped_early);
    assert_eq!(out.stats.spp_done, 2);
    assert!(out.image.pixels.iter().all(|p| p.is_finite()));
    // The two-pass image equals a plain 2-spp render.
    assert_eq!(out.image, render(&scene, &opts(2, 2)).unwrap().image);
}

/// Progress comes once per pass, in order, after the pass is in the image (each pass is
/// added while the next one renders): the last report is the whole render, and the image
/// is the one a render without a callback gives.
#[test]
fn progress_reports_every_pass_in_order() {
    let scene = small_canopy_scene();
    let seen = Arc::new(std::sync::Mutex::new(Vec::new()));
    let log = seen.clone();
    let out = render(
        &scene,
        &RenderOptions {
            progress: Some(Arc::new(move |p| {
                log.lock()
                    .unwrap()
                    .push((p.passes_done, p.spp_done, p.passes_total));
            })),
            progressive: true,
            ..opts(40, 2)
        },
    )
    .unwrap();
    // 40 spp, progressive: passes of 1, 1, 2, 4, 8, 16 and 8 samples.
    let want: Vec<(u32, u32, u32)> = [1, 2, 4, 8, 16, 32, 40]
        .iter()
        .enumerate()
        .map(|(i, &spp)| (i as u32 + 1, spp, 7))
        .collect();
    assert_eq!(*seen.lock().unwrap(), want);
    assert_eq!((out.stats.passes_done, out.stats.spp_done), (7, 40));
    assert_eq!(out.image, render(&scene, &opts(40, 1)).unwrap().image);
}

/// Passes of 16 from the first, or the progressive 1, 1, 2, 4, 8, 16: the same image bit
/// for bit (a pixel's samples are added one after the other whatever the passes), on one
/// thread or several; a time limit makes a render progressive (its first pass 1 spp).
#[test]
fn passes_do_not_change_the_image() {
    let scene = small_canopy_scene();
    let passes = |progressive: bool, threads: usize| {
        let seen = Arc::new(std::sync::Mutex::new(Vec::new()));
        let log = seen.clone();
        let out = render(
            &scene,
            &RenderOptions {
                progress: Some(Arc::new(move |p| log.lock().unwrap().push(p.spp_done))),
                progressive,
                ..opts(40, threads)
            },
        )
        .unwrap();
        let seen = seen.lock().unwrap().clone();
        (out.image, seen)
    };
    let (whole, seen) = passes(false, 2);
    assert_eq!(seen, [16, 32, 40]);
    let (ramp, seen) = passes(true, 1);
    assert_eq!(seen, [1, 2, 4, 8, 16, 32, 40]);
    assert_eq!(whole, ramp);
    assert_eq!(whole, passes(false, 1).0);
    // The sums too, not only the f32 image.
    let sums = |progressive: bool| {
        render(
            &scene,
            &RenderOptions {
                keep_sums: true,
                progressive,
                ..opts(40, 2)
            },
        )
        .unwrap()
        .sums
        .unwrap()
    };
    assert_eq!(sums(false), sums(true));
    // A time limit starts with a pass of one sample per pixel.
    let first = Arc::new(std::sync::Mutex::new(None));
    let log = first.clone();
    render(
        &scene,
        &RenderOptions {
            time_limit: Some(Duration::from_secs(600)),
            progress: Some(Arc::new(move |p| {
                log.lock().unwrap().get_or_insert(p.spp_done);
            })),
            ..opts(40, 2)
        },
    )
    .unwrap();
    assert_eq!(*first.lock().unwrap(), Some(1));
}

/// Bad options fail cleanly.
#[test]
fn bad_options_are_errors() {
    let scene = small_canopy_scene();
    assert!(render(&scene, &opts(0, 2)).is_err());
    assert!(render(&scene, &opts(1, 0)).is_err());
    let mut bad = scene.clone();
    bad.camera.look_at = bad.camera.position;
    assert!(render(&bad, &opts(1, 1)).is_err());
    let mut bad = scene;
    bad.meshes[0].material = 99;
    assert!(render(&bad, &opts(1, 1)).is_err());
}
