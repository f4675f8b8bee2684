//! Progress reporting for long bakes: the library calls a [`Progress`]; the CLI shows an
//! indicatif bar (percentage, rays per second, time left), as the thesis's SHBuilder did.

use std::time::Duration;

/// Receives progress from the bake's worker threads.
pub trait Progress: Sync {
    /// Called before each pass over the vertices (the direct pass, then each bounce): its
    /// name, how many vertices, and rays cast per vertex (0 for passes without rays). A stage
    /// of unknown length (the atlas unwrap) passes 0 vertices.
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

/// A progress bar on stderr, one per pass. Each pass's bar is a new one that ends drawn at
/// 100 %, so the terminal keeps one finished line per pass ("direct", "bounce 1", …) and no
/// half-drawn bar of the previous pass reappears when the next begins.
pub struct ProgressBar {
    bar: std::sync::RwLock<indicatif::ProgressBar>,
}

impl ProgressBar {
    pub fn new() -> ProgressBar {
        ProgressBar {
            bar: std::sync::RwLock::new(indicatif::ProgressBar::hidden()),
        }
    }
}

impl Default for ProgressBar {
    fn default() -> ProgressBar {
        ProgressBar::new()
    }
}

/// The rate column: rays per second for passes that cast rays, vertices per second for the
/// others, and nothing until there is a rate to show (no "0 vertices/s" at a pass's start).
fn rate(rays_per_vertex: u64, per_second: f64, w: &mut dyn std::fmt::Write) {
    let _ = if per_second <= 0.0 || !per_second.is_finite() {
        Ok(())
    } else if rays_per_vertex == 0 {
        write!(w, "{per_second:.0} vertices/s")
    } else {
        write!(
            w,
            "{:.1} Mrays/s",
            per_second * rays_per_vertex as f64 / 1e6
        )
    };
}

impl Progress for ProgressBar {
    fn begin(&self, stage: &str, vertices: u64, rays_per_vertex: u64) {
        let template = match vertices {
            0 => "{msg:>9} [{elapsed_precise}] {spinner}",
            _ => "{msg:>9} [{elapsed_precise}] {wide_bar} {percent:>3}% {rate} ETA {eta}",
        };
        let style = indicatif::ProgressStyle::with_template(template)
            .expect("the template is valid")
            .with_key(
                "rate",
                move |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                    rate(rays_per_vertex, state.per_sec(), w)
                },
            )
            // The spinner's frames; the last is what a finished stage shows.
            .tick_strings(&["-", "\\", "|", "/", "done"]);
        // Styled and named before it is first drawn; rates and time left are per pass.
        let bar = indicatif::ProgressBar::with_draw_target(
            (vertices > 0).then_some(vertices),
            indicatif::ProgressDrawTarget::stderr(),
        )
        .with_style(style)
        .with_message(stage.to_string());
        bar.enable_steady_tick(Duration::from_millis(250));
        *self.bar.write().expect("the bar's lock") = bar;
    }

    fn advance(&self, vertices: u64) {
        self.bar.read().expect("the bar's lock").inc(vertices);
    }

    fn finish(&self) {
        let mut bar = self.bar.write().expect("the bar's lock");
        if let Some(length) = bar.length() {
            bar.set_position(length);
        }
        bar.finish();
        // indicatif leaves the cursor at the end of the finished line; the next pass's bar
        // and the summary start on a line of their own. (No bar is drawn off a terminal.)
        if !bar.is_hidden() && std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            eprintln!();
        }
        *bar = indicatif::ProgressBar::hidden();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rate_column_is_empty_until_there_is_a_rate() {
        let text = |rays, per_second| {
            let mut s = String::new();
            rate(rays, per_second, &mut s);
            s
        };
        assert_eq!(text(0, 0.0), "");
        assert_eq!(text(1024, 0.0), "");
        assert_eq!(text(0, 1234.4), "1234 vertices/s");
        assert_eq!(text(1000, 2.5e3), "2.5 Mrays/s");
    }
}
