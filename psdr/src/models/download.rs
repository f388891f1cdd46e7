//! Downloading one pinned model into the models folder: resumable (an interrupted download stays in
//! `FILE.part` and continues with an HTTP range request), verified (the pinned size and SHA-256, or the part
//! is removed and nothing is installed), atomic (the verified part is renamed onto `FILE`, so a reader never
//! sees half a model).

use super::folder::{model_state, part_path, sha256_file, ModelState};
use super::manifest::ModelEntry;
use crate::error::{Error, Result};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// What `fetch_model` did.
#[derive(Clone, Debug, PartialEq)]
pub struct Fetched {
    pub path: PathBuf,
    /// Already there and valid: nothing downloaded.
    pub cached: bool,
    /// Bytes a previous, interrupted download had left (0: from the start).
    pub resumed_from: u64,
}

/// Fetches `entry` into `dir` unless it is there and valid. `progress(done, total)` is called as bytes arrive.
pub fn fetch_model(entry: &ModelEntry, dir: &Path, progress: &dyn Fn(u64, u64)) -> Result<Fetched> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, format!("cannot make the models folder: {e}")))?;
    let path = dir.join(&entry.file);
    if model_state(entry, dir, true)? == ModelState::Valid {
        return Ok(Fetched { path, cached: true, resumed_from: 0 });
    }
    let part = part_path(&path);
    let mut have = std::fs::metadata(&part).map(|m| m.len()).unwrap_or(0);
    if have > entry.size {
        // Not a prefix of the pinned file.
        remove(&part)?;
        have = 0;
    }
    let resumed_from = have;
    if have < entry.size {
        download(entry, &part, have, progress)?;
    }
    let got = std::fs::metadata(&part).map_err(|e| Error::io(&part, e))?.len();
    if got != entry.size {
        return Err(Error::io(
            &part,
            format!(
                "the download of {} stopped at {got} of {} bytes; run `psdr models fetch` again to continue it",
                entry.name, entry.size
            ),
        ));
    }
    let sum = sha256_file(&part)?;
    if sum != entry.sha256 {
        remove(&part)?;
        return Err(Error::io(
            &path,
            format!(
                "{} from {} has SHA-256 {sum}, not the pinned {}; it was removed and nothing was installed (a \
                 changed file at that URL, or a corrupted download: try again)",
                entry.name, entry.url, entry.sha256
            ),
        ));
    }
    std::fs::rename(&part, &path).map_err(|e| Error::io(&path, e))?;
    Ok(Fetched { path, cached: false, resumed_from })
}

fn remove(p: &Path) -> Result<()> {
    std::fs::remove_file(p).map_err(|e| Error::io(p, e))
}

/// Appends the bytes from `have` on to `part` (from 0 when the server ignores the range).
fn download(entry: &ModelEntry, part: &Path, have: u64, progress: &dyn Fn(u64, u64)) -> Result<()> {
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .timeout_connect(Some(Duration::from_secs(30)))
        .timeout_recv_response(Some(Duration::from_secs(60)))
        .timeout_recv_body(None)
        .http_status_as_error(false)
        .build()
        .into();
    let mut request = agent.get(&entry.url);
    if have > 0 {
        request = request.header("Range", format!("bytes={have}-"));
    }
    let offline = |e: String| {
        Error::Invalid(format!(
            "cannot download {} from {}: {e}. Without internet: download that URL elsewhere, check its SHA-256 is \
             {}, and put it at {}",
            entry.name,
            entry.url,
            entry.sha256,
            part.with_file_name(&entry.file).display()
        ))
    };
    let mut response = request.call().map_err(|e| offline(e.to_string()))?;
    let status = response.status().as_u16();
    let start = match status {
        206 => {
            // "bytes START-END/TOTAL": the server must continue where the part ends.
            let range = response.headers().get("content-range").and_then(|v| v.to_str().ok()).unwrap_or("");
            let from = range.strip_prefix("bytes ").and_then(|r| r.split('-').next()).and_then(|s| s.parse().ok());
            if from != Some(have) {
                return Err(offline(format!("asked for bytes {have}- and got a range '{range}'")));
            }
            have
        }
        200 => 0,
        _ => return Err(offline(format!("HTTP status {status}"))),
    };
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .append(start > 0)
        .write(true)
        .truncate(start == 0)
        .open(part)
        .map_err(|e| Error::io(part, e))?;
    let mut reader = response.body_mut().as_reader();
    let mut buf = vec![0u8; 256 * 1024];
    let mut done = start;
    progress(done, entry.size);
    loop {
        let n = match reader.read(&mut buf) {
            Ok(n) => n,
            Err(e) => {
                let _ = file.sync_all();
                return Err(Error::io(
                    part,
                    format!(
                        "the download of {} broke off after {done} of {} bytes ({e}); run `psdr models fetch` again \
                         to continue it",
                        entry.name, entry.size
                    ),
                ));
            }
        };
        if n == 0 {
            break;
        }
        if done + n as u64 > entry.size {
            drop(file);
            remove(part)?;
            return Err(offline(format!("the server sent more than the pinned {} bytes", entry.size)));
        }
        file.write_all(&buf[..n]).map_err(|e| Error::io(part, e))?;
        done += n as u64;
        progress(done, entry.size);
    }
    file.sync_all().map_err(|e| Error::io(part, e))
}
