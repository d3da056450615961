//! `stbn-gen generate --format ktx2`: one KTX2 3D texture per mask, read back with the `ktx2`
//! crate, whose texels equal the `.stbn` payload byte for byte.

use std::fs;
use std::path::Path;
use std::process::{Command, Output};

use stbn_build_support::Manifest;
use stbn_build_support::encode::encode_payload;
use stbn_runtime::Encoding;

const MANIFEST: &str = r#"(
    masks: [
        (name: "scalar_8", kind: Scalar, size: (16, 16, 8), seed: 1, encoding: Unorm8),
        (name: "blue2d_16", kind: Blue2D, size: (12, 10, 4), seed: 2, encoding: Unorm16),
        (name: "blue3d_f32", kind: Blue3D, size: (8, 8, 6), seed: 3, encoding: F32),
    ],
)"#;

fn stbn_gen(args: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_stbn-gen"))
        .args(args)
        .output()
        .expect("the binary runs")
}

#[test]
fn generate_writes_ktx2_textures_equal_to_the_embedded_payload() {
    let dir = tempfile::tempdir().unwrap();
    let manifest_path = dir.path().join("assets.ron");
    fs::write(&manifest_path, MANIFEST).unwrap();
    let out = dir.path().join("out");
    let output = stbn_gen(&[
        "generate".as_ref(),
        &manifest_path,
        "--out".as_ref(),
        &out,
        "--format".as_ref(),
        "ktx2".as_ref(),
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");

    let manifest = Manifest::parse(MANIFEST, &manifest_path).unwrap();
    for entry in manifest.masks() {
        let file = fs::read(out.join(format!("{}.ktx2", entry.name))).unwrap();
        assert!(
            !out.join(&entry.name).exists(),
            "no PNG folder with --format ktx2"
        );
        let reader = ktx2::Reader::new(&file[..]).unwrap();
        let header = reader.header();
        let format = match entry.encoding {
            Encoding::Unorm8 => ktx2::Format::R8_UNORM,
            Encoding::Unorm16 => ktx2::Format::R16_UNORM,
            Encoding::F32 => ktx2::Format::R32_SFLOAT,
        };
        assert_eq!(header.format, Some(format), "{}", entry.name);
        let spec = entry.spec();
        assert_eq!(
            (header.pixel_width, header.pixel_height, header.pixel_depth),
            (spec.width, spec.height, spec.depth),
            "{}",
            entry.name
        );
        assert_eq!(
            (header.layer_count, header.face_count, header.level_count),
            (0, 1, 1)
        );
        assert_eq!(header.supercompression_scheme, None);
        let (dfd, type_size) = ktx2::dfd::Basic::from_format(format).unwrap();
        assert_eq!(header.type_size, type_size);
        assert_eq!(reader.basic_dfd(), Some(&dfd), "{}", entry.name);

        let volume = stbn_gen::generate(&spec, stbn_gen::Observer::default()).unwrap();
        let payload = encode_payload(&volume, entry.encoding);
        let levels: Vec<_> = reader.levels().collect();
        assert_eq!(levels.len(), 1);
        assert!(
            levels[0].data == &payload[..],
            "{}: KTX2 texels differ from the .stbn payload",
            entry.name
        );
        assert_eq!(levels[0].uncompressed_byte_length, payload.len() as u64);
    }
    let report = fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("KTX2 3D textures"), "{report}");
}
