//! Progress bars for long stages (hidden when stderr is not a terminal).

use std::sync::Mutex;

use indicatif::{ProgressBar, ProgressStyle};

/// One bar per stage name, replaced when the stage changes.
pub struct StageBars {
    current: Mutex<Option<(String, ProgressBar)>>,
}

impl StageBars {
    /// No bar yet.
    pub fn new() -> Self {
        Self { current: Mutex::new(None) }
    }

    /// Reports `done` of `total` in `stage`.
    pub fn update(&self, stage: &str, done: u64, total: u64) {
        let Ok(mut current) = self.current.lock() else { return };
        let same = current.as_ref().is_some_and(|(name, _)| name == stage);
        if !same {
            if let Some((_, bar)) = current.take() {
                bar.finish();
            }
            let bar = ProgressBar::new(total);
            bar.set_style(
                ProgressStyle::with_template("{prefix:>10} [{bar:40}] {pos}/{len} {elapsed_precise} eta {eta}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            bar.set_prefix(stage.to_owned());
            *current = Some((stage.to_owned(), bar));
        }
        if let Some((_, bar)) = current.as_ref() {
            bar.set_length(total);
            bar.set_position(done);
        }
    }

    /// Finishes the last bar.
    pub fn finish(&self) {
        if let Ok(mut current) = self.current.lock()
            && let Some((_, bar)) = current.take()
        {
            bar.finish();
        }
    }
}
