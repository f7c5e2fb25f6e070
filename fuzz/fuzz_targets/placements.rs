//! Placement (instance) CSV files: transforms or an error naming the row, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = lamina_scene::instances::parse_instances_csv(text, std::path::Path::new("p.csv"));
});
