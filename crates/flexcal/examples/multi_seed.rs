//! The demo study over seed 1 and four other seeds: the acceptance figures
//! as min / median / max (the tables of `docs/demo.md`).
//!
//! ```text
//! cargo run --release -p flexcal --example multi_seed [OUT_DIR]
//! ```

use flexcal::study::multi_seed_study;

struct Lines;

impl flexcal::study::StudyObserver for Lines {
    fn finished(&mut self, line: &str) {
        eprintln!("{line}");
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "flexcal-demo-seeds".into());
    let summary = multi_seed_study(&[1, 2, 3, 4, 5], std::path::Path::new(&out), &mut Lines)?;
    println!("{}", summary.to_markdown());
    flexcal_io::write_atomic(
        std::path::Path::new(&out).join("multi_seed.json"),
        serde_json::to_string_pretty(&summary)? + "\n",
    )?;
    Ok(())
}
