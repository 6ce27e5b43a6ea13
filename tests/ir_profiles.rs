//! Target profiles: the built-in RON files load, round-trip, and agree with
//! the combiner backend's limits; files on disk load with clear errors.

use shadec::profile::{FragmentStage, Profile, BUILTIN};

#[test]
fn builtin_profiles_have_the_documented_limits() {
    let gf1 = Profile::builtin("geforce256").unwrap();
    assert_eq!(gf1.texture_units, 2);
    assert!(gf1.cube_maps && gf1.texture_shaders.is_none());
    assert_eq!(gf1.texture_bits, 8);
    let FragmentStage::Combiners(c) = &gf1.fragment else { panic!() };
    assert_eq!((c.general_combiners, c.constant_colors, c.per_stage_constants), (2, 2, false));

    let gf3 = Profile::builtin("geforce3").unwrap();
    assert_eq!(gf3.texture_units, 4);
    let ts = gf3.texture_shaders.as_ref().unwrap();
    assert!(ts.dot_product && ts.dependent_lookups);
    let FragmentStage::Combiners(c) = &gf3.fragment else { panic!() };
    assert_eq!((c.general_combiners, c.per_stage_constants), (8, true));

    let mt = Profile::builtin("multitexture").unwrap();
    assert_eq!(mt.fragment, FragmentStage::TextureEnv);
    for mode in ["modulate", "decal", "blend", "add"] {
        assert!(mt.texture_env_modes.iter().any(|m| m == mode), "{mode}");
    }
    assert_eq!(Profile::builtin("wgsl").unwrap().fragment, FragmentStage::Programmable);
}

#[test]
fn profiles_round_trip_through_ron_and_load_from_disk() {
    let dir = tempfile::tempdir().unwrap();
    for name in BUILTIN {
        let p = Profile::builtin(name).unwrap();
        let path = dir.path().join(format!("{name}.ron"));
        std::fs::write(&path, p.to_ron()).unwrap();
        assert_eq!(Profile::load(&path).unwrap(), p);
        // The shipped file is the embedded one.
        let shipped =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("profiles").join(format!("{name}.ron"));
        assert_eq!(Profile::load(&shipped).unwrap(), p);
    }
}

#[test]
fn the_parser_and_the_profiles_know_the_same_names() {
    assert_eq!(shadec::parser::resolve::PROFILES, BUILTIN);
}

#[test]
fn load_errors_name_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.ron");
    std::fs::write(&path, "Profile(name: \"x\", texture_units: \"two\")").unwrap();
    let e = Profile::load(&path).unwrap_err().to_string();
    assert!(e.contains("broken.ron: not a valid profile"), "{e}");
    let e = Profile::load(&dir.path().join("missing.ron")).unwrap_err().to_string();
    assert!(e.contains("missing.ron: cannot read the profile"), "{e}");
    let p = Profile::builtin("geforce256")
        .unwrap()
        .to_ron()
        .replace("texture_units: 2", "texture_units: 2, warp_drive: true");
    let e = Profile::from_ron(&p, "x.ron").unwrap_err().to_string();
    assert!(e.contains("warp_drive"), "{e}");
}
