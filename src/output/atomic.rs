//! Files written under a temporary name and renamed into place together.

use std::fs::File;
use std::path::{Path, PathBuf};

/// A set of output files being written. Each is created as `.<name>.tmp-<pid>` next to its
/// final path; [`Staging::commit`] renames them all, and dropping an uncommitted staging
/// removes them, so a failed run leaves no half-written file behind.
#[derive(Debug, Default)]
pub struct Staging {
    files: Vec<(PathBuf, PathBuf)>,
    committed: bool,
}

impl Staging {
    pub fn new() -> Self {
        Self::default()
    }

    /// Creates the temporary file that will become `path`.
    pub fn create(&mut self, path: &Path) -> std::io::Result<File> {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "output".into());
        let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
        let file = File::create(&tmp)?;
        self.files.push((tmp, path.to_path_buf()));
        Ok(file)
    }

    /// Renames every staged file to its final name.
    pub fn commit(mut self) -> std::io::Result<Vec<PathBuf>> {
        for (tmp, target) in &self.files {
            std::fs::rename(tmp, target)?;
        }
        self.committed = true;
        Ok(self.files.iter().map(|(_, t)| t.clone()).collect())
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        if !self.committed {
            for (tmp, _) in &self.files {
                let _ = std::fs::remove_file(tmp);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn scratch(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("hindsight-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn commit_renames_and_drop_cleans() {
        let dir = scratch("a");
        let mut s = Staging::new();
        s.create(&dir.join("x.parquet"))
            .unwrap()
            .write_all(b"x")
            .unwrap();
        assert!(!dir.join("x.parquet").exists());
        s.commit().unwrap();
        assert_eq!(std::fs::read(dir.join("x.parquet")).unwrap(), b"x");

        let mut s = Staging::new();
        s.create(&dir.join("y.parquet"))
            .unwrap()
            .write_all(b"y")
            .unwrap();
        drop(s);
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("x.parquet")]);
        std::fs::remove_dir_all(dir).unwrap();
    }
}
