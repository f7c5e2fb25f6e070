//! Generation time of trees of 10k, 100k and 1M leaves (or the counts given).
//!
//! `cargo run --release -p lamina-plant --example timing -- [leaves...]`

use lamina_plant::{PlantParams, generate_plant};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let counts: Vec<u32> = std::env::args()
        .skip(1)
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let counts = if counts.is_empty() {
        vec![10_000, 100_000, 1_000_000]
    } else {
        counts
    };
    println!(
        "{:>9} {:>8} {:>9} {:>10} {:>9} {:>8} {:>8} {:>8} {:>8}",
        "leaves", "points", "nodes", "branch_tri", "skeleton", "mesh", "leaves", "maps", "total"
    );
    for n in counts {
        let plant = generate_plant(&PlantParams::tree(1, n))?;
        let s = plant.stats;
        println!(
            "{:>9} {:>8} {:>9} {:>10} {:>8.3}s {:>7.3}s {:>7.3}s {:>7.3}s {:>7.3}s",
            s.leaves,
            s.attraction_points,
            s.nodes,
            s.branch_triangles,
            s.skeleton_s,
            s.mesh_s,
            s.leaves_s,
            s.leaf_maps_s,
            s.total_s
        );
    }
    Ok(())
}
