//! Progress reporting for long bakes: the library calls a [`Progress`]; the CLI shows an
//! indicatif bar (percentage, rays per second, time left), as the thesis's SHBuilder did.

use std::time::Duration;

/// Receives progress from the bake's worker threads.
pub trait Progress: Sync {
    /// Called once before any work: how many vertices, and rays per vertex.
    fn begin(&self, _vertices: u64, _rays_per_vertex: u64) {}
    /// Called from worker threads as vertices complete.
    fn advance(&self, vertices: u64);
    /// Called once when all vertices are done.
    fn finish(&self) {}
}

/// Reports nothing.
pub struct Silent;

impl Progress for Silent {
    fn advance(&self, _vertices: u64) {}
}

/// A progress bar on stderr.
pub struct ProgressBar {
    bar: indicatif::ProgressBar,
}

impl ProgressBar {
    pub fn new(label: &str) -> ProgressBar {
        let bar = indicatif::ProgressBar::hidden();
        bar.set_message(label.to_string());
        ProgressBar { bar }
    }
}

impl Progress for ProgressBar {
    fn begin(&self, vertices: u64, rays_per_vertex: u64) {
        let style = indicatif::ProgressStyle::with_template(
            "{msg} [{elapsed_precise}] {wide_bar} {percent:>3}% {rays} ETA {eta}",
        )
        .expect("the template is valid")
        .with_key(
            "rays",
            move |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                let per_second = state.per_sec() * rays_per_vertex as f64;
                let _ = if rays_per_vertex == 0 {
                    write!(w, "{:.0} vertices/s", state.per_sec())
                } else {
                    write!(w, "{:.1} Mrays/s", per_second / 1e6)
                };
            },
        );
        self.bar.set_style(style);
        self.bar.set_length(vertices);
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
