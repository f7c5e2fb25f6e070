//! Renders beyond one machine: a render split into parts by samples (`--part k/n`) or by
//! pixels (`--crop`), parts written as self-describing EXR files, merged exactly into the
//! image one machine would have made, and Slurm job arrays that run them.
//!
//! Modules:
//! * [`part`]: part files (EXR with the part's description in its header, the f64 sums carried exactly).
//! * [`merge`](mod@merge): checks that parts belong together and merges them.
//! * [`hash`]: the scene hash that ties parts to their scene.
//! * [`slurm`]: farm folders, job-array scripts, submission and status.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod error;
pub mod hash;
pub mod merge;
pub mod part;
pub mod slurm;

pub use error::FarmError;
pub use merge::{MergeSummary, Merged, merge, merge_files};
pub use part::{Part, PartInfo, read_part, read_part_info, write_part};
