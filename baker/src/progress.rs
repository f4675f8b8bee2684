//! Progress reporting for long bakes: the library calls a [`Progress`]; the CLI shows an
//! indicatif bar (percentage, rays per second, time left), as the thesis's SHBuilder did.

use std::time::Duration;

/// Receives progress from the bake's worker threads.
pub trait Progress: Sync {
    /// Called before each pass over the vertices (the direct pass, then each bounce): its
    /// name, how many vertices, and rays cast per vertex (0 for passes without rays).
    fn begin(&self, _stage: &str, _vertices: u64, _rays_per_vertex: u64) {}
    /// Called from worker threads as vertices complete.
    fn advance(&self, vertices: u64);
    /// Called when the pass's vertices are all done.
    fn finish(&self) {}
}

/// Reports nothing.
pub struct Silent;

impl Progress for Silent {
    fn advance(&self, _vertices: u64) {}
}

/// A progress bar on stderr, one per pass.
pub struct ProgressBar {
    bar: indicatif::ProgressBar,
}

impl ProgressBar {
    pub fn new() -> ProgressBar {
        ProgressBar {
            bar: indicatif::ProgressBar::hidden(),
        }
    }
}

impl Default for ProgressBar {
    fn default() -> ProgressBar {
        ProgressBar::new()
    }
}

impl Progress for ProgressBar {
    fn begin(&self, stage: &str, vertices: u64, rays_per_vertex: u64) {
        let style = indicatif::ProgressStyle::with_template(
            "{msg:>9} [{elapsed_precise}] {wide_bar} {percent:>3}% {rate} ETA {eta}",
        )
        .expect("the template is valid")
        .with_key(
            "rate",
            move |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = if rays_per_vertex == 0 {
                    write!(w, "{:.0} vertices/s", state.per_sec())
                } else {
                    write!(
                        w,
                        "{:.1} Mrays/s",
                        state.per_sec() * rays_per_vertex as f64 / 1e6
                    )
                };
            },
        );
        // Rates and time left are per pass: start each pass from zero.
        self.bar.reset();
        self.bar.set_style(style);
        self.bar.set_length(vertices);
        self.bar.set_message(stage.to_string());
        self.bar
            .set_draw_target(indicatif::ProgressDrawTarget::stderr());
        self.bar.enable_steady_tick(Duration::from_millis(250));
    }

    fn advance(&self, vertices: u64) {
        self.bar.inc(vertices);
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
