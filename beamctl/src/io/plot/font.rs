//! A TrueType font for plot text, found at run time (see the parent
//! module's `# Design`).

use plotters::style::FontStyle;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Candidate font files, most preferred first.
const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu-sans-fonts/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation-sans/LiberationSans-Regular.ttf",
    "/usr/share/fonts/truetype/noto/NotoSans-Regular.ttf",
    "/usr/share/fonts/noto/NotoSans-Regular.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "/Library/Fonts/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// Directories searched for any `*Sans*.ttf` when no known file exists.
const FONT_DIRS: &[&str] = &["/usr/share/fonts", "/usr/local/share/fonts"];

/// Register a sans-serif font with plotters once; true if one was found.
pub fn ensure_font() -> bool {
    static FOUND: OnceLock<bool> = OnceLock::new();
    *FOUND.get_or_init(|| {
        let candidates: Vec<PathBuf> = match std::env::var_os("BEAMCTL_FONT") {
            Some(p) => vec![PathBuf::from(p)],
            None => FONT_PATHS
                .iter()
                .map(PathBuf::from)
                .chain(FONT_DIRS.iter().filter_map(|d| find_ttf(Path::new(d), 4)))
                .collect(),
        };
        candidates.iter().any(|p| register(p))
    })
}

fn register(path: &Path) -> bool {
    let Ok(bytes) = std::fs::read(path) else {
        return false;
    };
    // plotters keeps fonts for the life of the process.
    let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
    plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok()
}

/// The first `*Sans*.ttf` (not mono, not bold/italic) below `dir`.
fn find_ttf(dir: &Path, depth: usize) -> Option<PathBuf> {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    entries.sort();
    for p in &entries {
        let name = p.file_name()?.to_string_lossy().to_lowercase();
        if p.is_file()
            && name.ends_with(".ttf")
            && name.contains("sans")
            && !["mono", "bold", "italic", "oblique", "light", "condensed"]
                .iter()
                .any(|s| name.contains(s))
        {
            return Some(p.clone());
        }
    }
    if depth == 0 {
        return None;
    }
    entries
        .iter()
        .filter(|p| p.is_dir())
        .find_map(|p| find_ttf(p, depth - 1))
}
