//! The `stbn-gen` binary under hostile input and interruption: every run ends (each is killed
//! and fails the test after a deadline, so a regression fails instead of hanging), errors come
//! before any work and name their file, and an interrupted run leaves the previous output as it
//! was.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// What a finished run printed.
struct Run {
    status: ExitStatus,
    stdout: String,
    stderr: String,
}

/// Starts `stbn-gen args…` with stdout and stderr in files of `logs`.
fn spawn(args: &[&Path], logs: &Path) -> Child {
    Command::new(env!("CARGO_BIN_EXE_stbn-gen"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(fs::File::create(logs.join("stdout")).unwrap())
        .stderr(fs::File::create(logs.join("stderr")).unwrap())
        .spawn()
        .expect("the binary starts")
}

/// Waits for `child` until `deadline`; kills it and fails the test if it is still running then.
fn wait(mut child: Child, logs: &Path, deadline: Duration) -> Run {
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!(
                "stbn-gen did not finish within {deadline:?}; stderr: {}",
                fs::read_to_string(logs.join("stderr")).unwrap_or_default()
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Run {
        status,
        stdout: fs::read_to_string(logs.join("stdout")).unwrap(),
        stderr: fs::read_to_string(logs.join("stderr")).unwrap(),
    }
}

/// Runs `stbn-gen args…` to its end, within `deadline`.
fn run(args: &[&Path], deadline: Duration) -> Run {
    let logs = tempfile::tempdir().unwrap();
    let child = spawn(args, logs.path());
    wait(child, logs.path(), deadline)
}

/// Asserts a clean failure: status 1 (not a signal or an abort), an `error: ` line holding every
/// one of `needles`, no panic.
fn assert_fails_with(run: &Run, needles: &[&str]) {
    let stderr = &run.stderr;
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "{stderr:?} lacks {needle:?}");
    }
    assert!(!stderr.contains("panicked"), "{stderr}");
}

fn write(path: &Path, text: &str) -> PathBuf {
    fs::write(path, text).unwrap();
    path.to_owned()
}

fn mkfifo(path: &Path) {
    let made = Command::new("mkfifo").arg(path).status().unwrap();
    assert!(made.success());
}

const MINUTE: Duration = Duration::from_secs(60);

#[test]
fn a_sigma_that_would_drop_the_kernel_centre_is_refused_instead_of_looping() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, field) in [
        ("Scalar", "sigma"),
        ("Blue2D", "sigma"),
        ("Blue3D", "sigma"),
        ("Blue3D", "sigma_time"),
        ("GoldenRatio2D", "sigma"),
    ] {
        let manifest = write(
            &dir.path().join("assets.ron"),
            &format!(
                "(masks: [(name: \"m\", kind: {kind}, size: (8, 8, 4), seed: 1, \
                 {field}: 1e-200, encoding: Unorm8)])"
            ),
        );
        let out = dir.path().join("out");
        let run = run(
            &["generate".as_ref(), &manifest, "--out".as_ref(), &out],
            MINUTE,
        );
        assert_fails_with(
            &run,
            &[&format!("field `{field}`"), "must be at least 1e-150"],
        );
        assert!(
            !out.exists(),
            "{kind}: nothing is written for a refused manifest"
        );
    }
}

#[cfg(unix)]
#[test]
fn fifos_and_endless_devices_are_refused_without_reading() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let fifo = dir.path().join("fifo.ron");
    mkfifo(&fifo);
    let run_ = run(
        &["generate".as_ref(), &fifo, "--out".as_ref(), &out],
        MINUTE,
    );
    assert_fails_with(&run_, &["fifo.ron", "not a regular file"]);

    mkfifo(&dir.path().join("pipe.png"));
    std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.hdr")).unwrap();
    for image in ["pipe.png", "zero.hdr"] {
        let manifest = write(
            &dir.path().join("assets.ron"),
            &format!(
                "(masks: [(name: \"m\", kind: EnvironmentMap, size: (8, 8, 4), seed: 1, \
                 image: \"{image}\", encoding: Unorm8)])"
            ),
        );
        let run = run(
            &["generate".as_ref(), &manifest, "--out".as_ref(), &out],
            MINUTE,
        );
        assert_fails_with(&run, &[image, "not a regular file", "field `image`"]);
    }

    // A slice that is a FIFO.
    let slices = dir.path().join("slices");
    fs::create_dir(&slices).unwrap();
    mkfifo(&slices.join("m_0.png"));
    let run = run(
        &["analyze".as_ref(), &slices, "--out".as_ref(), &out],
        MINUTE,
    );
    assert_fails_with(&run, &["m_0.png", "not a regular file"]);
}

/// A PNG of `width × height` 16-bit RGBA whose image data is an empty zlib stream.
fn lying_png(width: u32, height: u32) -> Vec<u8> {
    let mut ihdr = width.to_be_bytes().to_vec();
    ihdr.extend(height.to_be_bytes());
    ihdr.extend([16, 6, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    for (kind, data) in [
        (b"IHDR", ihdr),
        (b"IDAT", vec![0x78, 0x9c, 0x03, 0, 0, 0, 0, 1]),
        (b"IEND", Vec::new()),
    ] {
        let mut chunk = kind.to_vec();
        chunk.extend(&data);
        png.extend((data.len() as u32).to_be_bytes());
        png.extend(&chunk);
        let mut crc = !0u32;
        for &b in &chunk {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 == 1 {
                    (crc >> 1) ^ 0xEDB8_8320
                } else {
                    crc >> 1
                };
            }
        }
        png.extend((!crc).to_be_bytes());
    }
    png
}

#[test]
fn a_png_claiming_gigabytes_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let slices = dir.path().join("huge");
    fs::create_dir(&slices).unwrap();
    let png = lying_png(65535, 65535);
    assert!(png.len() < 100);
    fs::write(slices.join("huge_0.png"), png).unwrap();
    let out = dir.path().join("out");
    let run = run(
        &["analyze".as_ref(), &slices, "--out".as_ref(), &out],
        MINUTE,
    );
    assert_fails_with(
        &run,
        &[
            "huge_0.png",
            "declares 65535x65535 pixels, over the limit of 16777216",
        ],
    );
    assert!(!out.join("report.md").exists());
}

#[test]
fn analyze_warns_about_colour_channels_and_constant_slices() {
    let dir = tempfile::tempdir().unwrap();
    let slices = dir.path().join("colour");
    fs::create_dir(&slices).unwrap();
    for z in 0..2 {
        let file = fs::File::create(slices.join(format!("colour_{z}.png"))).unwrap();
        let mut encoder = png::Encoder::new(file, 2, 2);
        encoder.set_color(png::ColorType::Rgb);
        let mut writer = encoder.write_header().unwrap();
        // Slice 0 holds one value; slice 1 varies, with blue unlike red.
        let data: Vec<u8> = if z == 0 {
            vec![7; 12]
        } else {
            [10, 10, 99, 200, 200, 99, 50, 50, 99, 90, 90, 99].to_vec()
        };
        writer.write_image_data(&data).unwrap();
        writer.finish().unwrap();
    }
    let out = dir.path().join("out");
    let run = run(
        &["analyze".as_ref(), &slices, "--out".as_ref(), &out],
        MINUTE,
    );
    assert!(run.status.success(), "{}", run.stderr);
    assert!(
        run.stderr
            .contains("slice 1 (and maybe others) is a colour image"),
        "{}",
        run.stderr
    );
    assert!(
        run.stderr.contains("1 of 2 slices hold a single value"),
        "{}",
        run.stderr
    );
    let report = fs::read_to_string(out.join("report.md")).unwrap();
    assert_eq!(report.matches("**Warning:**").count(), 2, "{report}");
}

#[test]
fn refusals_come_before_any_output_and_name_their_cause() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    // An empty manifest is valid for build.rs, but nothing to generate.
    let empty = write(&dir.path().join("empty.ron"), "(masks: [])");
    let run_ = run(
        &["generate".as_ref(), &empty, "--out".as_ref(), &out],
        MINUTE,
    );
    assert_fails_with(&run_, &["empty.ron", "declares no masks"]);
    // Names of the report's folders.
    for name in ["plots", "csv", "DFT"] {
        let manifest = write(
            &dir.path().join("assets.ron"),
            &format!(
                "(masks: [(name: \"{name}\", kind: White, size: (4, 4, 2), seed: 1, \
                 encoding: Unorm8)])"
            ),
        );
        let run = run(
            &["generate".as_ref(), &manifest, "--out".as_ref(), &out],
            MINUTE,
        );
        assert_fails_with(
            &run,
            &["assets.ron:1:17:", "field `name`", "the report's folder"],
        );
    }
    assert!(!out.exists());

    // An output folder that cannot be one, before minutes of generation.
    let manifest = write(
        &dir.path().join("slow.ron"),
        "(masks: [(name: \"v\", kind: Vec4, size: (64, 64, 64), seed: 1, \
         swaps_per_pixel: 10000, encoding: Unorm8)])",
    );
    let file = write(&dir.path().join("file"), "");
    let start = Instant::now();
    let run = run(
        &[
            "generate".as_ref(),
            &manifest,
            "--out".as_ref(),
            &file.join("out"),
        ],
        MINUTE,
    );
    assert_fails_with(&run, &["cannot write to the output folder", "file/out"]);
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "{:?}",
        start.elapsed()
    );
}

/// Every file under `dir` (relative path → bytes), leaving out staging folders.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(folder) = stack.pop() {
        for entry in fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            let relative = path.strip_prefix(dir).unwrap().to_owned();
            if relative.to_str().unwrap().starts_with(".stbn-gen-staging-") {
                continue;
            }
            if path.is_dir() {
                stack.push(path);
            } else {
                files.insert(relative, fs::read(&path).unwrap());
            }
        }
    }
    files
}

/// The staging folders in `out`.
fn staging_folders(out: &Path) -> Vec<PathBuf> {
    fs::read_dir(out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .unwrap()
                .to_str()
                .unwrap()
                .starts_with(".stbn-gen-staging-")
        })
        .collect()
}

#[cfg(unix)]
#[test]
fn an_interrupted_run_leaves_the_previous_output_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let manifest = |seed: u32, swaps: u32| {
        write(
            &dir.path().join(format!("assets_{seed}.ron")),
            &format!(
                "(masks: [
                    (name: \"s\", kind: Scalar, size: (16, 16, 8), seed: {seed}, encoding: Unorm8),
                    (name: \"v\", kind: Vec2, size: (32, 32, 16), seed: {seed}, \
                     swaps_per_pixel: {swaps}, assignment_passes: 0, encoding: Unorm8),
                ])"
            ),
        )
    };
    let first = manifest(1, 1);
    let run_ = run(
        &["generate".as_ref(), &first, "--out".as_ref(), &out],
        MINUTE,
    );
    assert!(run_.status.success(), "{}", run_.stderr);
    let before = snapshot(&out);
    assert!(before.contains_key(Path::new("s/s_7.png")), "{before:?}");
    assert!(before.contains_key(Path::new("report.md")));

    // Other slices for `s`, and a `v` that takes far longer than the test waits.
    let second = manifest(2, 10000);
    let logs = tempfile::tempdir().unwrap();
    let child = spawn(
        &["generate".as_ref(), &second, "--out".as_ref(), &out],
        logs.path(),
    );
    // Interrupt once `s` is complete in the staging folder, while `v` is being optimised.
    let start = Instant::now();
    while !staging_folders(&out)
        .iter()
        .any(|staging| staging.join("s/s_7.png").exists())
    {
        assert!(start.elapsed() < MINUTE, "the second run never wrote `s`");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(200));
    let pid = child.id().to_string();
    let sent = Command::new("kill").args(["-INT", &pid]).status().unwrap();
    assert!(sent.success());
    let interrupted = wait(child, logs.path(), MINUTE);
    assert!(!interrupted.status.success(), "{}", interrupted.stdout);
    assert_eq!(snapshot(&out), before, "the previous output changed");

    // The next run finishes and clears the folder the interrupted one left.
    let run = run(
        &["generate".as_ref(), &first, "--out".as_ref(), &out],
        MINUTE,
    );
    assert!(run.status.success(), "{}", run.stderr);
    assert_eq!(staging_folders(&out), Vec::<PathBuf>::new());
    assert_eq!(
        snapshot(&out).keys().collect::<Vec<_>>(),
        before.keys().collect::<Vec<_>>()
    );
}
