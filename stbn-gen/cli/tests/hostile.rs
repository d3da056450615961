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

/// `stbn-gen args…`, with SIGINT and SIGTERM at their default disposition whatever this test
/// inherited (a shell running it in the background ignores SIGINT, and children inherit that).
fn command(args: &[&Path]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_stbn-gen"));
    command.args(args).stdin(Stdio::null());
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: the closure runs in the child between fork and exec, where only
        // async-signal-safe calls are allowed: it calls signal(2), which is one, and allocates
        // nothing.
        unsafe {
            command.pre_exec(|| {
                libc::signal(libc::SIGINT, libc::SIG_DFL);
                libc::signal(libc::SIGTERM, libc::SIG_DFL);
                Ok(())
            });
        }
    }
    command
}

/// Starts `stbn-gen args…` with stdout and stderr in files of `logs`.
fn spawn(args: &[&Path], logs: &Path) -> Child {
    command(args)
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

/// Every file under `dir` (relative path → bytes), leaving out staging folders and their locks.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(folder) = stack.pop() {
        for entry in fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            let relative = path.strip_prefix(dir).unwrap().to_owned();
            if relative.starts_with(".stbn-gen")
                && relative
                    .file_name()
                    .unwrap()
                    .to_str()
                    .unwrap()
                    .starts_with("staging-")
            {
                continue;
            }
            let meta = fs::symlink_metadata(&path).unwrap();
            if meta.is_dir() {
                stack.push(path);
            } else if meta.is_symlink() {
                let target = fs::read_link(&path).unwrap();
                files.insert(relative, target.into_os_string().into_encoded_bytes());
            } else {
                files.insert(relative, fs::read(&path).unwrap());
            }
        }
    }
    files
}

/// Asserts that two snapshots hold the same files with the same bytes, naming those that differ.
fn assert_same(
    after: &BTreeMap<PathBuf, Vec<u8>>,
    before: &BTreeMap<PathBuf, Vec<u8>>,
    what: &str,
) {
    let differing: Vec<&PathBuf> = before
        .keys()
        .chain(after.keys())
        .filter(|path| before.get(*path) != after.get(*path))
        .collect();
    assert!(
        differing.is_empty(),
        "{what} changed the previous output: {differing:?}"
    );
}

/// The staging folders (and their lock files) in `out`.
fn staging_folders(out: &Path) -> Vec<PathBuf> {
    let Ok(entries) = fs::read_dir(out.join(".stbn-gen")) else {
        return Vec::new();
    };
    entries
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .unwrap()
                .to_str()
                .unwrap()
                .starts_with("staging-")
        })
        .collect()
}

/// Waits until a staging folder in `out` that is not one of `earlier` holds `path` (the run has
/// staged it); `earlier` are folders stopped runs left, which hold it too.
#[cfg(unix)]
fn wait_until_staged(out: &Path, path: &str, earlier: &[PathBuf]) -> PathBuf {
    let start = Instant::now();
    loop {
        if let Some(staging) = staging_folders(out)
            .into_iter()
            .find(|staging| !earlier.contains(staging) && staging.join("out").join(path).exists())
        {
            return staging;
        }
        assert!(start.elapsed() < MINUTE, "the run never staged {path}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A manifest `assets_<seed>.ron` in `dir`: a quick scalar mask `s`, then a Vec2 mask `v` of
/// `swaps` swaps per pixel (10000 takes far longer than any test waits).
fn two_masks(dir: &Path, seed: u32, swaps: u32) -> PathBuf {
    write(
        &dir.join(format!("assets_{seed}.ron")),
        &format!(
            "(masks: [
                (name: \"s\", kind: Scalar, size: (16, 16, 8), seed: {seed}, encoding: Unorm8),
                (name: \"v\", kind: Vec2, size: (32, 32, 16), seed: {seed}, \
                 swaps_per_pixel: {swaps}, assignment_passes: 0, encoding: Unorm8),
            ])"
        ),
    )
}

/// A manifest `one_<seed>.ron` in `dir` of one small scalar mask `s` (a run takes a moment).
fn one_mask(dir: &Path, seed: u32) -> PathBuf {
    write(
        &dir.join(format!("one_{seed}.ron")),
        &format!(
            "(masks: [(name: \"s\", kind: Scalar, size: (8, 8, 4), seed: {seed}, \
             encoding: Unorm8)])"
        ),
    )
}

/// `generate manifest --out out`, which must succeed.
fn generate(manifest: &Path, out: &Path) -> Run {
    let run = run(
        &["generate".as_ref(), manifest, "--out".as_ref(), out],
        MINUTE,
    );
    assert!(run.status.success(), "{}", run.stderr);
    run
}

#[cfg(unix)]
#[test]
fn an_interrupted_run_leaves_the_previous_output_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let first = two_masks(dir.path(), 1, 1);
    generate(&first, &out);
    let before = snapshot(&out);
    assert!(before.contains_key(Path::new("s/s_7.png")), "{before:?}");
    assert!(before.contains_key(Path::new("report.md")));
    assert!(before.contains_key(Path::new(".stbn-gen/output")));

    // Other slices for `s`, and a `v` that takes far longer than the test waits: stopped once
    // `s` is complete in the staging folder, while `v` is being optimised.
    let second = two_masks(dir.path(), 2, 10000);
    for signal in [libc::SIGINT, libc::SIGTERM, libc::SIGKILL] {
        let logs = tempfile::tempdir().unwrap();
        let earlier = staging_folders(&out);
        let child = spawn(
            &["generate".as_ref(), &second, "--out".as_ref(), &out],
            logs.path(),
        );
        wait_until_staged(&out, "s/s_7.png", &earlier);
        std::thread::sleep(Duration::from_millis(200));
        let pid = libc::pid_t::try_from(child.id()).unwrap();
        // SAFETY: sends a signal to the child this test started (not yet waited for, so its pid
        // is not reused); no memory is passed.
        assert_eq!(unsafe { libc::kill(pid, signal) }, 0);
        let stopped = wait(child, logs.path(), MINUTE);
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(stopped.status.signal(), Some(signal), "{}", stopped.stderr);
        assert_same(&snapshot(&out), &before, &format!("signal {signal}"));
    }

    // The next run finishes and clears the folders the stopped ones left.
    assert!(!staging_folders(&out).is_empty());
    generate(&first, &out);
    assert_eq!(staging_folders(&out), Vec::<PathBuf>::new());
    // The same files (report.md holds timings, so not the same bytes).
    assert_eq!(
        snapshot(&out).keys().collect::<Vec<_>>(),
        before.keys().collect::<Vec<_>>()
    );
}

#[cfg(unix)]
#[test]
fn a_run_failing_after_its_first_mask_leaves_the_previous_output_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    generate(&two_masks(dir.path(), 1, 1), &out);
    let before = snapshot(&out);
    // `v`'s folder cannot be created once `s` is staged: an I/O error late in the run.
    let logs = tempfile::tempdir().unwrap();
    let child = spawn(
        &[
            "generate".as_ref(),
            &two_masks(dir.path(), 2, 100),
            "--out".as_ref(),
            &out,
        ],
        logs.path(),
    );
    let staging = wait_until_staged(&out, "s/s_7.png", &[]);
    // Paused while the obstacle is placed, so `v` cannot be written first.
    let pid = libc::pid_t::try_from(child.id()).unwrap();
    // SAFETY: signals the child this test started and has not waited for; no memory is passed.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGSTOP) }, 0);
    fs::write(staging.join("out/v"), "in the way").unwrap();
    // SAFETY: as above.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGCONT) }, 0);
    let failed = wait(child, logs.path(), MINUTE);
    assert_fails_with(&failed, &["out/v"]);
    assert_same(&snapshot(&out), &before, "a failed run");
    assert_eq!(staging_folders(&out), Vec::<PathBuf>::new());
}

#[test]
fn files_stbn_gen_did_not_write_are_never_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let manifest = one_mask(dir.path(), 1);
    // Someone's files, where the report and a mask would go, and elsewhere.
    for (path, text) in [
        ("csv/sales.csv", "month,sales\n"),
        ("plots/fig1.png", "a figure"),
        ("report.md", "# My report\n"),
        ("s/notes.txt", "notes"),
        ("data/sales.csv", "month,sales\n"),
        ("notes.txt", "notes"),
    ] {
        fs::create_dir_all(out.join(path).parent().unwrap()).unwrap();
        fs::write(out.join(path), text).unwrap();
    }
    let before = snapshot(&out);
    let refused = run(
        &["generate".as_ref(), &manifest, "--out".as_ref(), &out],
        MINUTE,
    );
    assert_fails_with(
        &refused,
        &[
            "4 paths that stbn-gen did not write",
            "out/csv, ",
            "out/plots, ",
            "out/report.md, ",
            "out/s; ",
            "nothing was written",
        ],
    );
    assert!(refused.stdout.is_empty(), "{}", refused.stdout);
    assert_same(&snapshot(&out), &before, "a refused run");

    // Without those in the way, the run writes beside the rest, and a second run replaces its
    // own output.
    for path in ["csv", "plots", "s"] {
        fs::remove_dir_all(out.join(path)).unwrap();
    }
    fs::remove_file(out.join("report.md")).unwrap();
    generate(&manifest, &out);
    let first = snapshot(&out);
    for path in ["data/sales.csv", "notes.txt"] {
        assert_eq!(first[Path::new(path)], before[Path::new(path)], "{path}");
    }
    generate(&one_mask(dir.path(), 2), &out);
    let second = snapshot(&out);
    assert_ne!(
        first[Path::new("s/s_0.png")],
        second[Path::new("s/s_0.png")]
    );
    assert_eq!(
        first.keys().collect::<Vec<_>>(),
        second.keys().collect::<Vec<_>>()
    );
    assert_eq!(
        second[Path::new("data/sales.csv")],
        before[Path::new("data/sales.csv")]
    );

    // A file put into a mask's folder since, and a symlink in place of one: refused, named.
    fs::write(out.join("s/notes.txt"), "notes").unwrap();
    let refused = run(
        &["generate".as_ref(), &manifest, "--out".as_ref(), &out],
        MINUTE,
    );
    assert_fails_with(
        &refused,
        &["1 path that stbn-gen did not write", "s/notes.txt"],
    );
    #[cfg(unix)]
    {
        fs::remove_dir_all(out.join("s")).unwrap();
        std::os::unix::fs::symlink(out.join("data"), out.join("s")).unwrap();
        let before = snapshot(&out);
        let refused = run(
            &["generate".as_ref(), &manifest, "--out".as_ref(), &out],
            MINUTE,
        );
        assert_fails_with(&refused, &["1 path", "out/s;"]);
        assert_same(&snapshot(&out), &before, "a refused run");
    }
}

#[test]
fn output_into_the_current_folder_keeps_its_other_files() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = one_mask(dir.path(), 1);
    let work = dir.path().join("work");
    fs::create_dir(&work).unwrap();
    fs::write(work.join("Cargo.toml"), "[package]\n").unwrap();
    for _ in 0..2 {
        let output = command(&[
            "generate".as_ref(),
            &manifest,
            "--out".as_ref(),
            ".".as_ref(),
        ])
        .current_dir(&work)
        .output()
        .unwrap();
        assert!(output.status.success(), "{output:?}");
    }
    assert_eq!(
        fs::read_to_string(work.join("Cargo.toml")).unwrap(),
        "[package]\n"
    );
    assert!(work.join("s/s_3.png").exists() && work.join("report.md").exists());
}

#[test]
fn a_closed_stdout_or_stderr_neither_panics_nor_loses_the_output() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = one_mask(dir.path(), 1);
    let out = dir.path().join("out");
    // Both pipes closed before the run prints anything, as `| head -1` closes stdout after a
    // line.
    let mut child = command(&["generate".as_ref(), &manifest, "--out".as_ref(), &out])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    drop(child.stderr.take());
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        assert!(start.elapsed() < MINUTE, "the run did not finish");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(status.code(), Some(0));
    assert!(out.join("s/s_3.png").exists() && out.join("report.md").exists());

    // An error with stderr closed: status 1, not a panic's 101.
    let mut child = command(&[
        "generate".as_ref(),
        &dir.path().join("missing.ron"),
        "--out".as_ref(),
        &out,
    ])
    .stdout(Stdio::null())
    .stderr(Stdio::piped())
    .spawn()
    .unwrap();
    drop(child.stderr.take());
    assert_eq!(child.wait().unwrap().code(), Some(1));
}

#[test]
fn a_staging_folder_whose_lock_is_held_is_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = one_mask(dir.path(), 1);
    let out = dir.path().join("out");
    generate(&manifest, &out);
    // A live run's staging folder, its lock held by this process (another PID namespace looks
    // the same: a pid that means nothing here), and an abandoned one.
    let state = out.join(".stbn-gen");
    let live = state.join("staging-999999999");
    let lock = fs::File::create(state.join("staging-999999999.lock")).unwrap();
    lock.lock().unwrap();
    let dead = state.join("staging-abandoned");
    fs::File::create(state.join("staging-abandoned.lock")).unwrap();
    for folder in [&live, &dead] {
        fs::create_dir_all(folder.join("out/s")).unwrap();
        fs::write(folder.join("out/s/s_0.png"), "staged").unwrap();
    }
    generate(&manifest, &out);
    assert!(live.join("out/s/s_0.png").exists());
    assert!(!dead.exists());
    assert!(!state.join("staging-abandoned.lock").exists());
    drop(lock);
    generate(&manifest, &out);
    assert_eq!(staging_folders(&out), Vec::<PathBuf>::new());
}

#[test]
fn an_out_that_is_a_file_is_refused_by_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(&dir.path().join("file"), "mine");
    let manifest = two_masks(dir.path(), 1, 10000);
    let slices = dir.path().join("slices");
    fs::create_dir(&slices).unwrap();
    let start = Instant::now();
    for args in [
        vec![
            "generate".as_ref(),
            manifest.as_path(),
            "--out".as_ref(),
            &file,
        ],
        vec!["analyze".as_ref(), &slices, "--out".as_ref(), &file],
        vec!["tradeoff".as_ref(), "--out".as_ref(), &file],
    ] {
        let run = run(&args, MINUTE);
        assert_fails_with(&run, &["the output folder", "file is a file, not a folder"]);
    }
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "{:?}",
        start.elapsed()
    );
    assert_eq!(fs::read_to_string(&file).unwrap(), "mine");
}

#[test]
fn tradeoff_checks_its_output_folder_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    fs::create_dir(&out).unwrap();
    fs::write(out.join("threads.csv"), "mine").unwrap();
    fs::write(out.join("notes.txt"), "mine").unwrap();
    let start = Instant::now();
    let refused = run(&["tradeoff".as_ref(), "--out".as_ref(), &out], MINUTE);
    assert_fails_with(&refused, &["threads.csv", "did not write"]);
    assert!(refused.stdout.is_empty(), "{}", refused.stdout);
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "{:?}",
        start.elapsed()
    );

    fs::remove_file(out.join("threads.csv")).unwrap();
    let args: [&Path; 6] = [
        "tradeoff".as_ref(),
        "--quick".as_ref(),
        "--only".as_ref(),
        "threads".as_ref(),
        "--out".as_ref(),
        &out,
    ];
    for _ in 0..2 {
        let done = run(&args, MINUTE);
        assert!(done.status.success(), "{}", done.stderr);
    }
    assert_eq!(fs::read_to_string(out.join("notes.txt")).unwrap(), "mine");
    for file in ["threads.csv", "threads.md", "tradeoff.md"] {
        assert!(out.join(file).exists(), "{file}");
    }
    assert_eq!(staging_folders(&out), Vec::<PathBuf>::new());
}

/// Writes 4×4 8-bit slices `<name>_<z>.png` for each `z` of `frames` into `dir`.
fn slices(dir: &Path, name: &str, frames: std::ops::Range<usize>) {
    fs::create_dir_all(dir).unwrap();
    for z in frames {
        let file = fs::File::create(dir.join(format!("{name}_{z}.png"))).unwrap();
        let mut encoder = png::Encoder::new(file, 4, 4);
        encoder.set_color(png::ColorType::Grayscale);
        let mut writer = encoder.write_header().unwrap();
        let data: Vec<u8> = (0..16).map(|i| ((i * 16 + z * 5) % 256) as u8).collect();
        writer.write_image_data(&data).unwrap();
        writer.finish().unwrap();
    }
}

#[test]
fn analyze_refuses_slices_not_starting_at_zero_and_names_too_long_for_its_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let late = dir.path().join("late");
    slices(&late, "s", 5..9);
    let run_ = run(&["analyze".as_ref(), &late, "--out".as_ref(), &out], MINUTE);
    assert_fails_with(&run_, &["late: slices 0–4 are missing", "s_5.png"]);
    assert!(!out.exists());

    // `dft/00_<name>_xy.png`: 245 characters fit 255 bytes, 249 do not.
    let long = dir.path().join("long");
    slices(&long, &"n".repeat(249), 0..2);
    let run_ = run(&["analyze".as_ref(), &long, "--out".as_ref(), &out], MINUTE);
    assert_fails_with(&run_, &["is 249 characters long", "at most 245"]);
    assert!(!out.exists());
    let fits = dir.path().join("fits");
    slices(&fits, &"n".repeat(245), 0..2);
    let run_ = run(&["analyze".as_ref(), &fits, "--out".as_ref(), &out], MINUTE);
    assert!(run_.status.success(), "{}", run_.stderr);
    assert!(out.join("report.md").exists());
}
