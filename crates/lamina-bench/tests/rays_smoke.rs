//! The `rays` benchmark's quick scenes are what they claim: rays hit some of them, not all,
//! and the leaf matte lets rays through.

use glam::Vec2;
use lamina_accel::{Accel, PrimRef, Ray};
use lamina_bench::rays::{
    CARDS_BOX, CARDS_VIEW, CROWN, LeafMatte, MATTE_SIZE, Scale, TREE_BOX, TREE_VIEW, camera_rays,
    cards_scene, random_rays, shadow_rays, tree_scene,
};

fn hits(accel: &Accel, rays: &[Ray], f: &impl Fn(u32, Vec2) -> bool) -> usize {
    rays.iter()
        .filter(|r| accel.intersect(r, PrimRef::NONE, f).is_some())
        .count()
}

#[test]
fn quick_scenes_are_hit_plausibly() {
    let matte = LeafMatte::new(MATTE_SIZE);
    let f = |_: u32, uv: Vec2| matte.opaque(uv);
    let n = Scale::QUICK.cards as usize;

    let cards = cards_scene(Scale::QUICK.cards, 1, Some(&matte));
    assert_eq!(cards.world.prims.len(), n + 1, "cards and the ground");
    assert!(cards.masks[0].is_some());
    let opaque = cards_scene(Scale::QUICK.cards, 1, None);
    assert!(opaque.masks.is_empty() && opaque.world.prims.iter().all(|p| p.alpha.is_none()));
    let (cards, opaque) = (
        Accel::build(&cards).unwrap(),
        Accel::build(&opaque).unwrap(),
    );

    let camera = camera_rays(&CARDS_VIEW, 64, 64);
    let random = random_rays(CARDS_BOX, 4000, 11);
    let c = hits(&cards, &camera, &f);
    // The ground fills the lower part of the view, cards are scattered above it.
    assert!(
        c > camera.len() / 4 && c < camera.len(),
        "camera: {c} of {}",
        camera.len()
    );
    let (ra, ro) = (hits(&cards, &random, &f), hits(&opaque, &random, &f));
    assert!(
        ra > 0 && ro < random.len(),
        "random: {ra} with the matte, {ro} without"
    );
    // The matte's holes let some rays through that opaque cards stop.
    assert!(ra < ro, "random: {ra} with the matte, {ro} without");
    let shadow = shadow_rays(CARDS_BOX, 4000, 12);
    let s = shadow
        .iter()
        .filter(|r| cards.occluded(r, PrimRef::NONE, &f))
        .count();
    assert!(s > 0 && s < shadow.len(), "shadow: {s} of {}", shadow.len());

    let mut tree = tree_scene(Scale::QUICK.leaves, 2);
    assert_eq!(
        (tree.instances.len(), tree.prototypes[0].prims.len()),
        (100_000, 64)
    );
    assert_eq!(tree.world.prims.len(), 384);
    let (centre, radii) = CROWN;
    assert!(tree.instances.iter().all(|i| {
        let p = (glam::Vec3::from(i.object_to_world.translation) - centre) / radii;
        p.length() <= 1.0 + 1e-5
    }));
    // An unoptimised build of 100k instances takes seconds: trace the first 20k.
    tree.instances.truncate(20_000);
    let tree = Accel::build(&tree).unwrap();
    let camera = camera_rays(&TREE_VIEW, 64, 64);
    let t = hits(&tree, &camera, &f);
    // The crown and the trunk fill the middle of the view, the sky the corners.
    assert!(
        t > camera.len() / 5 && t < camera.len(),
        "tree camera: {t} of {}",
        camera.len()
    );
    let random = random_rays(TREE_BOX, 4000, 21);
    let tr = hits(&tree, &random, &f);
    assert!(
        tr > 0 && tr < random.len(),
        "tree random: {tr} of {}",
        random.len()
    );
}
