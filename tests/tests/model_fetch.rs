//! `psdr models fetch` without the internet: a small HTTP server on 127.0.0.1 serves the tiny contract models
//! (tests/models) under a manifest of the pinned one's shape. Checked: download, verification and install,
//! the cache hit, an interrupted download continued by a range request, a server that ignores ranges, a
//! checksum or size that does not match (nothing installed), the offline message, and the fetched models
//! used by the observations (ONNX Runtime: skipped without it unless PSDR_REQUIRE_ORT=1).

use psdr::models::{fetch_model, model_state, part_path, sha256_file, Manifest, ModelEntry, ModelState};
use psdr::vision::{ObservationInputs, Observations};
use psdr_tests::temp_dir;
use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// How the server answers a request.
#[derive(Clone, Copy)]
enum Behaviour {
    /// The bytes, honouring `Range: bytes=N-` with 206.
    Serve,
    /// Announces the whole length, sends this many bytes and closes the connection.
    CutAfter(usize),
    /// 200 with the whole body, whatever the range.
    IgnoreRanges,
}

/// A one-file HTTP server on 127.0.0.1; `requests` keeps each request's Range header ("" when none).
struct Server {
    url: String,
    requests: Arc<Mutex<Vec<String>>>,
}

impl Server {
    /// Serves `body`; request k is answered by `behaviours[k]` (the last one for every later request).
    fn start(body: Vec<u8>, behaviours: Vec<Behaviour>) -> Server {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let url = format!("http://{}/model.onnx", listener.local_addr().unwrap());
        let requests = Arc::new(Mutex::new(vec![]));
        let r = requests.clone();
        std::thread::spawn(move || {
            for stream in listener.incoming().flatten() {
                let range = read_request(&stream);
                let k = {
                    let mut r = r.lock().unwrap();
                    r.push(range.clone());
                    r.len() - 1
                };
                let behaviour = behaviours[k.min(behaviours.len() - 1)];
                respond(stream, &body, &range, behaviour);
            }
        });
        Server { url, requests }
    }

    fn ranges(&self) -> Vec<String> {
        self.requests.lock().unwrap().clone()
    }
}

/// The request's Range header value ("" when none); reads up to the blank line.
fn read_request(stream: &TcpStream) -> String {
    let mut reader = BufReader::new(stream);
    let mut range = String::new();
    loop {
        let mut line = String::new();
        if reader.read_line(&mut line).unwrap_or(0) == 0 || line.trim().is_empty() {
            return range;
        }
        if let Some((k, v)) = line.split_once(':') {
            if k.trim().eq_ignore_ascii_case("range") {
                range = v.trim().to_string();
            }
        }
    }
}

fn respond(mut s: TcpStream, body: &[u8], range: &str, behaviour: Behaviour) {
    let from: Option<usize> =
        range.strip_prefix("bytes=").and_then(|r| r.strip_suffix('-')).and_then(|n| n.parse().ok());
    let (status, start) = match (behaviour, from) {
        (Behaviour::Serve, Some(n)) | (Behaviour::CutAfter(_), Some(n)) => ("206 Partial Content", n),
        _ => ("200 OK", 0),
    };
    let rest = &body[start..];
    let mut head = format!("HTTP/1.1 {status}\r\nContent-Length: {}\r\nConnection: close\r\n", rest.len());
    if start > 0 {
        head += &format!("Content-Range: bytes {start}-{}/{}\r\n", body.len() - 1, body.len());
    }
    head += "\r\n";
    let _ = s.write_all(head.as_bytes());
    let send = match behaviour {
        Behaviour::CutAfter(n) => &rest[..n.min(rest.len())],
        _ => rest,
    };
    let _ = s.write_all(send);
    let _ = s.flush();
    let _ = s.shutdown(std::net::Shutdown::Both);
}

fn tiny(name: &str) -> Vec<u8> {
    std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("models").join(name)).unwrap()
}

fn sha256(bytes: &[u8]) -> String {
    // A folder per call: the tests run in parallel and temp_dir empties its folder.
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let dir = temp_dir(&format!("fetch-sha-{}", CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed)));
    let p = dir.join("b");
    std::fs::write(&p, bytes).unwrap();
    sha256_file(&p).unwrap()
}

/// A manifest entry like the pinned depth model's, for bytes served at `url`.
fn entry(file: &str, url: &str, bytes: &[u8]) -> ModelEntry {
    ModelEntry {
        name: file.trim_end_matches(".onnx").into(),
        file: file.into(),
        url: url.into(),
        size: bytes.len() as u64,
        sha256: sha256(bytes),
        licence: "MIT".into(),
        source: "tests/models".into(),
        contract: "the tiny contract model".into(),
    }
}

#[test]
fn a_fetch_downloads_verifies_installs_and_then_hits_the_cache() {
    let body = tiny("tiny_depth.onnx");
    let server = Server::start(body.clone(), vec![Behaviour::Serve]);
    let dir = temp_dir("fetch-basic").join("models");
    let e = entry("depth.onnx", &server.url, &body);
    assert_eq!(model_state(&e, &dir, true).unwrap(), ModelState::Missing);
    let seen = Mutex::new(vec![]);
    let f = fetch_model(&e, &dir, &|done, total| seen.lock().unwrap().push((done, total))).unwrap();
    assert!(!f.cached && f.resumed_from == 0);
    assert_eq!(std::fs::read(dir.join("depth.onnx")).unwrap(), body);
    assert!(!part_path(&dir.join("depth.onnx")).exists(), "the part is renamed onto the file");
    let seen = seen.into_inner().unwrap();
    assert_eq!(seen.last(), Some(&(body.len() as u64, body.len() as u64)), "progress ends at the total");
    assert_eq!(model_state(&e, &dir, true).unwrap(), ModelState::Valid);
    // Present and valid: no second request.
    let again = fetch_model(&e, &dir, &|_, _| {}).unwrap();
    assert!(again.cached);
    assert_eq!(server.ranges().len(), 1);
}

#[test]
fn an_interrupted_download_continues_with_a_range_request() {
    let body = tiny("tiny_segmentation.onnx");
    let cut = body.len() / 3;
    let server = Server::start(body.clone(), vec![Behaviour::CutAfter(cut), Behaviour::Serve]);
    let dir = temp_dir("fetch-resume");
    let e = entry("segmentation.onnx", &server.url, &body);
    let err = fetch_model(&e, &dir, &|_, _| {}).unwrap_err().to_string();
    assert!(err.contains("psdr models fetch") && err.contains("again"), "{err}");
    assert!(!dir.join("segmentation.onnx").exists(), "nothing installed from a broken download");
    let kept = std::fs::metadata(part_path(&dir.join("segmentation.onnx"))).unwrap().len();
    assert!(kept > 0 && kept <= cut as u64, "the part keeps what arrived: {kept} of {cut}");
    assert_eq!(model_state(&e, &dir, false).unwrap(), ModelState::Partial(kept));
    let f = fetch_model(&e, &dir, &|_, _| {}).unwrap();
    assert_eq!(f.resumed_from, kept);
    assert_eq!(server.ranges(), vec![String::new(), format!("bytes={kept}-")]);
    assert_eq!(std::fs::read(&f.path).unwrap(), body);
}

#[test]
fn a_server_that_ignores_ranges_restarts_the_file() {
    let body = tiny("tiny_fov.onnx");
    let server = Server::start(body.clone(), vec![Behaviour::IgnoreRanges]);
    let dir = temp_dir("fetch-norange");
    let e = entry("fov.onnx", &server.url, &body);
    std::fs::write(part_path(&dir.join("fov.onnx")), &body[..body.len() / 2]).unwrap();
    let f = fetch_model(&e, &dir, &|_, _| {}).unwrap();
    assert!(server.ranges()[0].starts_with("bytes="), "it asked to continue");
    assert_eq!(std::fs::read(&f.path).unwrap(), body, "the 200 body replaced the part, not appended to it");
}

#[test]
fn a_wrong_checksum_or_size_installs_nothing() {
    let body = tiny("tiny_depth.onnx");
    let server = Server::start(body.clone(), vec![Behaviour::Serve]);
    let dir = temp_dir("fetch-bad");
    let mut e = entry("depth.onnx", &server.url, &body);
    e.sha256 = "0".repeat(64);
    let err = fetch_model(&e, &dir, &|_, _| {}).unwrap_err().to_string();
    assert!(
        err.contains(&sha256(&body)) && err.contains(&"0".repeat(64)) && err.contains("nothing was installed"),
        "{err}"
    );
    assert!(!dir.join("depth.onnx").exists() && !part_path(&dir.join("depth.onnx")).exists());
    // A file longer than the pinned size: stopped, and the part removed.
    let mut short = entry("depth.onnx", &server.url, &body[..100]);
    short.sha256 = sha256(&body[..100]);
    let err = fetch_model(&short, &dir, &|_, _| {}).unwrap_err().to_string();
    assert!(err.contains("more than the pinned 100 bytes"), "{err}");
    assert!(!dir.join("depth.onnx").exists() && !part_path(&dir.join("depth.onnx")).exists());
    // A file of the model's name that is not the pinned one is reported, then replaced by the verified one.
    std::fs::write(dir.join("depth.onnx"), b"not a model").unwrap();
    let good = entry("depth.onnx", &server.url, &body);
    assert!(matches!(model_state(&good, &dir, true).unwrap(), ModelState::Different(_)));
    fetch_model(&good, &dir, &|_, _| {}).unwrap();
    assert_eq!(model_state(&good, &dir, true).unwrap(), ModelState::Valid);
}

#[test]
fn offline_the_message_names_the_url_and_where_to_put_the_file() {
    // A port nothing listens on.
    let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let url = format!("http://127.0.0.1:{port}/depth.onnx");
    let dir = temp_dir("fetch-offline");
    let e = entry("depth.onnx", &url, b"x");
    let err = fetch_model(&e, &dir, &|_, _| {}).unwrap_err().to_string();
    assert!(err.contains(&url) && err.contains(&dir.join("depth.onnx").display().to_string()), "{err}");
    // A run that needs depth and has no source says how to get the pinned model, by command and by hand.
    let photo = dir.join("bare.png");
    image::RgbImage::from_pixel(16, 12, image::Rgb([120, 110, 100])).save(&photo).unwrap();
    let o = Observations::resolve(&ObservationInputs { models: None, ..ObservationInputs::new(&photo) }).unwrap();
    let msg = o.require_depth().unwrap_err().to_string();
    let pinned = Manifest::pinned();
    let depth = pinned.by_file("depth.onnx").unwrap();
    assert!(msg.contains("psdr models fetch") && msg.contains(&depth.url) && msg.contains(&depth.sha256), "{msg}");
    let msg = o.require_instances().unwrap_err().to_string();
    assert!(msg.contains("psdr models fetch") && msg.contains("segmentation.onnx"), "{msg}");
}

#[test]
fn an_empty_psdr_models_means_unset() {
    // The only test in this binary that touches the variable (the others pass their folders explicitly).
    std::env::set_var("PSDR_MODELS", "");
    assert_eq!(psdr::models::models_env(), None);
    assert_eq!(psdr::models::fetch_folder(None), psdr::models::cache_folder());
    std::env::set_var("PSDR_MODELS", "/some/where");
    assert_eq!(psdr::models::models_folder(None), Some(PathBuf::from("/some/where")));
    assert_eq!(psdr::models::models_folder(Some(Path::new("/flag"))), Some(PathBuf::from("/flag")));
    std::env::remove_var("PSDR_MODELS");
}

#[test]
fn fetched_models_are_what_the_observations_run() {
    let depth = tiny("tiny_depth.onnx");
    let seg = tiny("tiny_segmentation.onnx");
    let (sd, ss) =
        (Server::start(depth.clone(), vec![Behaviour::Serve]), Server::start(seg.clone(), vec![Behaviour::Serve]));
    let dir = temp_dir("fetch-use").join("models");
    fetch_model(&entry("depth.onnx", &sd.url, &depth), &dir, &|_, _| {}).unwrap();
    fetch_model(&entry("segmentation.onnx", &ss.url, &seg), &dir, &|_, _| {}).unwrap();
    // A photo with nothing beside it: red floor below, green wall above (the tiny segmentation's classes).
    let photo = temp_dir("fetch-use-photo").join("photo.png");
    image::RgbImage::from_fn(56, 42, |_, y| if y > 20 { image::Rgb([230, 20, 20]) } else { image::Rgb([20, 230, 20]) })
        .save(&photo)
        .unwrap();
    let o =
        match Observations::resolve(&ObservationInputs { models: Some(dir.clone()), ..ObservationInputs::new(&photo) })
        {
            Ok(o) => o,
            Err(e) if e.to_string().contains("ONNX Runtime not found") => {
                assert!(std::env::var_os("PSDR_REQUIRE_ORT").is_none(), "PSDR_REQUIRE_ORT is set: {e}");
                eprintln!("skipping: {e}");
                return;
            }
            Err(e) => panic!("{e}"),
        };
    // The model's disparity, made metric on the floor and wall the segmentation found (or left relative).
    assert!(o.depth.is_some() && o.sources["depth"].contains("(disparity)"), "{:?}", o.sources);
    let classes: Vec<&str> = o.instances.as_ref().unwrap().instances.iter().map(|i| i.class.as_str()).collect();
    assert!(classes.contains(&"floor") && classes.contains(&"wall"), "{classes:?}");
    assert!(
        o.sources["depth"].contains("depth.onnx") && o.sources["instances"].contains("segmentation.onnx"),
        "{:?}",
        o.sources
    );
}
