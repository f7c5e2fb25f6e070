//! Single-file outputs that replace only what lamina wrote.
//!
//! Every file lamina writes carries a mark naming the program, in the place its format
//! keeps such a note:
//!
//! | type | where the mark is |
//! |---|---|
//! | PNG | a `tEXt` chunk, keyword `Software` (a registered PNG keyword), right after `IHDR` |
//! | JPEG | a `COM` (comment) segment after the `APPn` segments |
//! | OpenEXR | the standard `software` string attribute of the (first) header |
//! | GLB (binary glTF) | `asset.generator` in the JSON chunk |
//! | CSV and other text tables | a first line `# lamina <version>...` ([`text_mark_line`]), a comment to `numpy.loadtxt`, R's `read.csv(comment.char = "#")` and pandas' `comment="#"` |
//!
//! The mark's text is [`GENERATOR`] (`lamina <version>`); a file is lamina's when its mark
//! starts with `lamina`. Viewers and other tools ignore the mark; lamina's own readers do
//! too.
//!
//! [`check_file`] is the rule every command applies to a file it was told to write, before
//! its work and again just before writing: a missing file is fine; a file lamina wrote is
//! replaced; anything else (a photo, another program's render, a file lamina wrote before
//! it marked its files) is refused with an error naming it, unless the user passed
//! `--force` ([`Replace::Force`]). A folder at the path, or a path that is one of the
//! command's own inputs, is refused even with `--force`.

use crate::folder::Replace;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The text of lamina's mark: `lamina <version>`.
pub const GENERATOR: &str = concat!("lamina ", env!("CARGO_PKG_VERSION"));

/// How many bytes of an existing file are read to find its mark. lamina puts the mark
/// within the first few hundred bytes; a GLB's JSON chunk may be longer, so its limit is
/// the JSON chunk's own length, up to [`MAX_GLB_JSON`].
const HEAD_BYTES: u64 = 64 * 1024;
/// The largest GLB JSON chunk read to find `asset.generator` (bytes).
const MAX_GLB_JSON: u64 = 64 * 1024 * 1024;

/// What is at a path lamina was asked to write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileState {
    /// Nothing: the file will be created.
    Absent,
    /// A file carrying lamina's mark.
    Ours,
    /// A file without the mark (not lamina's, or from a lamina that did not mark files).
    Foreign,
    /// A folder (or another non-file).
    NotAFile,
}

/// Why a file will not be written. Nothing was changed.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// The file exists and lamina did not write it.
    #[error(
        "'{path}' exists and was not written by lamina; lamina replaces only files it wrote \
         (pass --force to replace it, or name another file)"
    )]
    Foreign {
        /// The existing file.
        path: PathBuf,
    },
    /// A folder (or something else that is not a file) is at the path.
    #[error("'{path}' is a folder, not a file: name a file to write")]
    NotAFile {
        /// The path.
        path: PathBuf,
    },
    /// The path is one of the command's inputs.
    #[error("'{path}' is one of this command's inputs; name another file to write")]
    OverwritesInput {
        /// The input named as output.
        path: PathBuf,
    },
    /// The existing file could not be read to look for the mark.
    #[error("cannot read '{path}' to see whether lamina wrote it: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
}

/// Whether the file at `path` is absent, lamina's, foreign or not a file.
pub fn file_state(path: &Path) -> Result<FileState, FileError> {
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(FileState::Absent),
        Err(source) => {
            return Err(FileError::Io {
                path: path.to_owned(),
                source,
            });
        }
    };
    // A symbolic link is judged by what it points to (the rename replaces the link itself,
    // never its target, so the target is safe either way).
    let meta = if meta.file_type().is_symlink() {
        match std::fs::metadata(path) {
            Ok(m) => m,
            // A dangling link: nothing of the user's would be lost but the link.
            Err(_) => return Ok(FileState::Foreign),
        }
    } else {
        meta
    };
    if !meta.is_file() {
        return Ok(FileState::NotAFile);
    }
    let io = |source| FileError::Io {
        path: path.to_owned(),
        source,
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let mut head = Vec::new();
    (&mut file)
        .take(HEAD_BYTES)
        .read_to_end(&mut head)
        .map_err(io)?;
    if head.starts_with(b"glTF") && head.len() >= 20 {
        let json_len = u64::from(u32::from_le_bytes(head[12..16].try_into().unwrap()));
        if json_len <= MAX_GLB_JSON && 20 + json_len > head.len() as u64 {
            (&mut file)
                .take(20 + json_len - head.len() as u64)
                .read_to_end(&mut head)
                .map_err(io)?;
        }
    }
    Ok(if mark_of(&head).is_some_and(is_lamina) {
        FileState::Ours
    } else {
        FileState::Foreign
    })
}

/// The rule for a file a command was told to write (see the module docs): `Ok` when it may
/// be written, else the reason, naming the file. `inputs` are the command's input files;
/// naming one as output is refused even with [`Replace::Force`].
pub fn check_file(path: &Path, replace: Replace, inputs: &[PathBuf]) -> Result<(), FileError> {
    let state = file_state(path)?;
    if state == FileState::NotAFile {
        return Err(FileError::NotAFile {
            path: path.to_owned(),
        });
    }
    if state == FileState::Absent {
        return Ok(());
    }
    if let Ok(target) = path.canonicalize()
        && inputs
            .iter()
            .any(|i| i.canonicalize().is_ok_and(|i| i == target))
    {
        return Err(FileError::OverwritesInput {
            path: path.to_owned(),
        });
    }
    match (state, replace) {
        (FileState::Foreign, Replace::IfOurs) => Err(FileError::Foreign {
            path: path.to_owned(),
        }),
        _ => Ok(()),
    }
}

fn is_lamina(mark: String) -> bool {
    mark.starts_with("lamina")
}

/// The program mark found in the first bytes of a file (PNG `tEXt Software`, JPEG `COM`,
/// EXR `software`, GLB `asset.generator`), if any.
pub fn mark_of(bytes: &[u8]) -> Option<String> {
    if bytes.starts_with(PNG_SIGNATURE) {
        png_mark(bytes)
    } else if bytes.starts_with(&[0xFF, 0xD8]) {
        jpeg_mark(bytes)
    } else if bytes.starts_with(&EXR_MAGIC) {
        exr_mark(bytes)
    } else if bytes.starts_with(b"glTF") {
        glb_mark(bytes)
    } else if let Some(rest) = bytes.strip_prefix(b"# lamina") {
        let line = rest.split(|&b| b == b'\n').next().unwrap_or_default();
        Some(format!(
            "lamina{}",
            String::from_utf8_lossy(line).trim_end()
        ))
    } else {
        None
    }
}

/// The first line of a text table lamina writes (CSV): `# lamina <version>`, then `detail`
/// (what made it, e.g. the model and its inputs) when not empty. No line break.
pub fn text_mark_line(detail: &str) -> String {
    if detail.is_empty() {
        format!("# {GENERATOR}")
    } else {
        format!("# {GENERATOR}: {detail}")
    }
}

const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
const PNG_KEYWORD: &[u8] = b"Software";

/// Adds lamina's mark to encoded PNG or JPEG bytes (other bytes are returned unchanged).
/// EXR and GLB carry the mark from their encoders.
pub fn mark_encoded(bytes: Vec<u8>) -> Vec<u8> {
    if bytes.starts_with(PNG_SIGNATURE) {
        mark_png(bytes)
    } else if bytes.starts_with(&[0xFF, 0xD8]) {
        mark_jpeg(bytes)
    } else {
        bytes
    }
}

fn be32(b: &[u8], at: usize) -> Option<usize> {
    Some(u32::from_be_bytes(b.get(at..at + 4)?.try_into().ok()?) as usize)
}

fn png_mark(b: &[u8]) -> Option<String> {
    let mut at = 8;
    loop {
        let len = be32(b, at)?;
        let kind = b.get(at + 4..at + 8)?;
        if kind == b"IDAT" || kind == b"IEND" {
            return None;
        }
        let data = b.get(at + 8..at + 8 + len)?;
        if kind == b"tEXt"
            && let Some(text) = data.strip_prefix(PNG_KEYWORD)
            && let Some(text) = text.strip_prefix(b"\0")
        {
            return Some(String::from_utf8_lossy(text).into_owned());
        }
        at += 12 + len;
    }
}

fn mark_png(mut b: Vec<u8>) -> Vec<u8> {
    // IHDR is always the first chunk, 13 bytes of data: it ends at 8 + 4 + 4 + 13 + 4.
    const AFTER_IHDR: usize = 33;
    if b.get(12..16) != Some(b"IHDR") || b.len() < AFTER_IHDR {
        return b;
    }
    let mut data = PNG_KEYWORD.to_vec();
    data.push(0);
    data.extend_from_slice(GENERATOR.as_bytes());
    let mut chunk = Vec::with_capacity(data.len() + 12);
    chunk.extend_from_slice(&(data.len() as u32).to_be_bytes());
    chunk.extend_from_slice(b"tEXt");
    chunk.extend_from_slice(&data);
    let crc = crc32(&chunk[4..]);
    chunk.extend_from_slice(&crc.to_be_bytes());
    b.splice(AFTER_IHDR..AFTER_IHDR, chunk);
    b
}

/// CRC-32 (ISO 3309, the polynomial PNG uses), bitwise: the mark is a few bytes.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &byte in bytes {
        crc ^= u32::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// The JPEG segments before the image data: `(marker, start, end)` of each, from SOI on.
fn jpeg_segments(b: &[u8]) -> impl Iterator<Item = (u8, usize, usize)> + '_ {
    let mut at = 2;
    std::iter::from_fn(move || {
        if b.get(at) != Some(&0xFF) {
            return None;
        }
        let marker = *b.get(at + 1)?;
        // Start of scan: entropy-coded data follows, no more header segments.
        if marker == 0xDA {
            return None;
        }
        let len = u16::from_be_bytes(b.get(at + 2..at + 4)?.try_into().ok()?) as usize;
        let start = at;
        at += 2 + len;
        Some((marker, start, at))
    })
}

fn jpeg_mark(b: &[u8]) -> Option<String> {
    jpeg_segments(b)
        .find(|&(marker, _, _)| marker == 0xFE)
        .and_then(|(_, start, end)| b.get(start + 4..end))
        .map(|text| String::from_utf8_lossy(text).into_owned())
}

fn mark_jpeg(mut b: Vec<u8>) -> Vec<u8> {
    // After the APPn segments (JFIF's APP0 must directly follow SOI).
    let at = jpeg_segments(&b)
        .take_while(|&(marker, _, _)| (0xE0..=0xEF).contains(&marker))
        .last()
        .map_or(2, |(_, _, end)| end);
    let mut seg = vec![0xFF, 0xFE];
    seg.extend_from_slice(&((GENERATOR.len() + 2) as u16).to_be_bytes());
    seg.extend_from_slice(GENERATOR.as_bytes());
    b.splice(at..at, seg);
    b
}

fn exr_mark(b: &[u8]) -> Option<String> {
    // Magic (4), version and flags (4), then attributes: name\0 type\0 size(i32 LE) value,
    // ended by an empty name.
    let mut at = 8;
    let cstr = |at: usize| -> Option<(&[u8], usize)> {
        let len = b.get(at..)?.iter().position(|&c| c == 0)?;
        Some((&b[at..at + len], at + len + 1))
    };
    loop {
        let (name, next) = cstr(at)?;
        if name.is_empty() {
            return None;
        }
        let (kind, next) = cstr(next)?;
        let size = i32::from_le_bytes(b.get(next..next + 4)?.try_into().ok()?);
        let size = usize::try_from(size).ok()?;
        let value = b.get(next + 4..next + 4 + size)?;
        if name == b"software" && kind == b"string" {
            return Some(String::from_utf8_lossy(value).into_owned());
        }
        at = next + 4 + size;
    }
}

fn glb_mark(b: &[u8]) -> Option<String> {
    let len = u32::from_le_bytes(b.get(12..16)?.try_into().ok()?) as usize;
    if b.get(16..20)? != b"JSON" {
        return None;
    }
    let doc: serde_json::Value = serde_json::from_slice(b.get(20..20 + len)?).ok()?;
    doc.get("asset")?
        .get("generator")?
        .as_str()
        .map(str::to_owned)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("lamina-io-owned-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn crc32_matches_the_png_specification_check_value() {
        // The standard check value of CRC-32 over "123456789".
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn marked_png_and_jpeg_still_decode_and_carry_the_mark() {
        let img = image::RgbImage::from_fn(5, 3, |x, y| image::Rgb([x as u8 * 40, y as u8, 7]));
        for format in [image::ImageFormat::Png, image::ImageFormat::Jpeg] {
            let mut bytes = std::io::Cursor::new(Vec::new());
            img.write_to(&mut bytes, format).unwrap();
            let plain = bytes.into_inner();
            assert_eq!(mark_of(&plain), None, "{format:?}");
            let marked = mark_encoded(plain.clone());
            assert_eq!(mark_of(&marked).as_deref(), Some(GENERATOR), "{format:?}");
            let a = image::load_from_memory(&plain).unwrap().to_rgb8();
            let b = image::load_from_memory(&marked).unwrap().to_rgb8();
            assert_eq!(a, b, "{format:?}: the mark changed the pixels");
        }
        // The PNG reader checks chunk CRCs: a wrong CRC would make the decoder fail, so
        // decoding above also proves the tEXt chunk well-formed. Check the chunk order too.
        let mut bytes = std::io::Cursor::new(Vec::new());
        img.write_to(&mut bytes, image::ImageFormat::Png).unwrap();
        let marked = mark_encoded(bytes.into_inner());
        assert_eq!(&marked[37..41], b"tEXt");
    }

    #[test]
    fn a_png_decoder_sees_the_software_text() {
        let img = image::GrayImage::new(2, 2);
        let mut bytes = std::io::Cursor::new(Vec::new());
        img.write_to(&mut bytes, image::ImageFormat::Png).unwrap();
        let marked = mark_encoded(bytes.into_inner());
        let mut reader = png::Decoder::new(std::io::Cursor::new(marked))
            .read_info()
            .unwrap();
        let info = reader.info();
        let text = &info.uncompressed_latin1_text;
        assert_eq!(text.len(), 1, "{text:?}");
        assert_eq!(text[0].keyword, "Software");
        assert_eq!(text[0].text, GENERATOR);
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        reader.next_frame(&mut buf).unwrap();
    }

    #[test]
    fn the_rule_for_existing_files() {
        let d = scratch("rule");
        let absent = d.join("new.png");
        let ours = d.join("ours.png");
        let photo = d.join("photo.png");
        let img = image::RgbImage::new(3, 3);
        crate::save_image(&ours, &img).unwrap();
        let mut plain = std::io::Cursor::new(Vec::new());
        img.write_to(&mut plain, image::ImageFormat::Png).unwrap();
        std::fs::write(&photo, plain.into_inner()).unwrap();
        std::fs::create_dir(d.join("folder.png")).unwrap();

        assert_eq!(file_state(&absent).unwrap(), FileState::Absent);
        assert_eq!(file_state(&ours).unwrap(), FileState::Ours);
        assert_eq!(file_state(&photo).unwrap(), FileState::Foreign);
        assert_eq!(
            file_state(&d.join("folder.png")).unwrap(),
            FileState::NotAFile
        );

        check_file(&absent, Replace::IfOurs, &[]).unwrap();
        check_file(&ours, Replace::IfOurs, &[]).unwrap();
        let e = check_file(&photo, Replace::IfOurs, &[]).unwrap_err();
        assert!(matches!(e, FileError::Foreign { .. }), "{e}");
        assert!(e.to_string().contains("photo.png"), "{e}");
        assert!(e.to_string().contains("--force"), "{e}");
        check_file(&photo, Replace::Force, &[]).unwrap();
        let e = check_file(&d.join("folder.png"), Replace::Force, &[]).unwrap_err();
        assert!(matches!(e, FileError::NotAFile { .. }), "{e}");
        // An input is never an output, not even lamina's own file with --force.
        let e = check_file(&ours, Replace::Force, std::slice::from_ref(&ours)).unwrap_err();
        assert!(matches!(e, FileError::OverwritesInput { .. }), "{e}");
        // Text files, empty files and truncated images are foreign.
        for (name, bytes) in [
            ("notes.txt", &b"my notes"[..]),
            ("empty.png", &b""[..]),
            ("cut.png", &PNG_SIGNATURE[..6]),
        ] {
            let p = d.join(name);
            std::fs::write(&p, bytes).unwrap();
            assert_eq!(file_state(&p).unwrap(), FileState::Foreign, "{name}");
        }
    }

    #[test]
    fn text_tables_carry_the_mark_on_their_first_line() {
        let line = text_mark_line("PROSPECT-D");
        let csv = format!("{line}\nwavelength_nm,reflectance\n400,0.1\n");
        let mark = mark_of(csv.as_bytes()).unwrap();
        assert!(mark.starts_with(GENERATOR), "{mark}");
        assert!(mark_of(b"wavelength_nm,reflectance\n400,0.1\n").is_none());
        assert!(mark_of(b"# measured by hand\n400,0.1\n").is_none());
    }

    #[test]
    fn glb_generator_is_read_from_the_json_chunk() {
        let glb = |generator: &str| {
            let mut json = format!(r#"{{"asset":{{"version":"2.0","generator":"{generator}"}}}}"#)
                .into_bytes();
            while json.len() % 4 != 0 {
                json.push(b' ');
            }
            let mut b = b"glTF".to_vec();
            b.extend_from_slice(&2u32.to_le_bytes());
            b.extend_from_slice(&((20 + json.len()) as u32).to_le_bytes());
            b.extend_from_slice(&(json.len() as u32).to_le_bytes());
            b.extend_from_slice(b"JSON");
            b.extend_from_slice(&json);
            b
        };
        assert_eq!(mark_of(&glb(GENERATOR)).as_deref(), Some(GENERATOR));
        assert_eq!(
            mark_of(&glb("Khronos glTF Blender I/O")).as_deref(),
            Some("Khronos glTF Blender I/O")
        );
        let d = scratch("glb");
        let p = d.join("tree.glb");
        std::fs::write(&p, glb("Khronos glTF Blender I/O")).unwrap();
        assert_eq!(file_state(&p).unwrap(), FileState::Foreign);
        std::fs::write(&p, glb(GENERATOR)).unwrap();
        assert_eq!(file_state(&p).unwrap(), FileState::Ours);
    }
}
