//! The benchmarks' output files and who wrote them: a benchmark replaces a file only when
//! an earlier run of it wrote it (or with `--force`), as every lamina command does
//! (`lamina_io::check_file`). JSON reports carry a top-level `"generator"` naming the
//! benchmark; CSV tables, PNG frames and plots carry lamina's mark.

use anyhow::{Result, bail};
use std::path::Path;

/// Refuses to let a benchmark write its JSON report to `path` when a file there is not an
/// earlier report of it (a JSON object whose `"generator"` is `generator`), unless `force`.
/// `flag` names the option or file in the message.
pub fn check_json_target(path: &Path, generator: &str, force: bool, flag: &str) -> Result<()> {
    let Ok(meta) = std::fs::metadata(path) else {
        return Ok(()); // nothing there
    };
    if meta.is_dir() {
        bail!("{flag} {}: is a folder; name a file", path.display());
    }
    let ours = std::fs::read(path)
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .is_some_and(|v| v.get("generator").and_then(|g| g.as_str()) == Some(generator));
    if !ours && !force {
        bail!(
            "{flag} {}: the file exists and is not a report of this benchmark; \
             it is left as it is (pass --force to replace it, or name another file)",
            path.display()
        );
    }
    Ok(())
}

/// Refuses to let a benchmark write the table, frame or plot `path` when a file there does
/// not carry lamina's mark, unless `force` (`lamina_io::check_file`'s rule).
pub fn check_marked_target(path: &Path, force: bool) -> Result<()> {
    let replace = if force {
        lamina_io::Replace::Force
    } else {
        lamina_io::Replace::IfOurs
    };
    lamina_io::check_file(path, replace, &[])?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_foreign_file_is_refused_and_an_earlier_report_replaced() {
        let dir = std::env::temp_dir().join(format!("lamina-bench-report-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let json = dir.join("r.json");
        assert!(check_json_target(&json, "g", false, "--json").is_ok());
        std::fs::write(&json, "[1, 2]").unwrap();
        let e = check_json_target(&json, "g", false, "--json").unwrap_err();
        assert!(
            e.to_string().contains("not a report of this benchmark"),
            "{e}"
        );
        assert!(check_json_target(&json, "g", true, "--json").is_ok());
        std::fs::write(&json, r#"{"generator": "g", "runs": []}"#).unwrap();
        assert!(check_json_target(&json, "g", false, "--json").is_ok());
        let csv = dir.join("t.csv");
        std::fs::write(&csv, "a,b\n1,2\n").unwrap();
        assert!(check_marked_target(&csv, false).is_err());
        assert!(check_marked_target(&csv, true).is_ok());
        std::fs::write(&csv, format!("{}\na,b\n", lamina_io::text_mark_line("t"))).unwrap();
        assert!(check_marked_target(&csv, false).is_ok());
        assert_eq!(
            std::fs::read_to_string(&json).unwrap(),
            r#"{"generator": "g", "runs": []}"#
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
