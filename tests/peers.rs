//! Accuracy gates of the peers (`methods/*/method.toml` with `peer_of`), each run through
//! `pointsight visible --method NAME` beside the family of ours it pairs with, on small
//! synthetic clouds: CGAL's HPR set identical to our `hpr` at the same γ; point-cloud-utils'
//! ray cast against our `raycast` with discs at equal radius (Jaccard ≥ 0.99); VTK's z-buffer
//! selection (in an offscreen EGL or OSMesa window) against a brute force of its own rule
//! (Jaccard ≥ 0.99) and beside our `splat`, on sphere-20000; PCL's occluded voxels against a
//! brute-force voxel walk on a 10³ grid; the py3dtiles LOD peer's selection shrinking as the
//! view recedes; the COPC peer's selection (copc_converter's octree) equal to a brute force
//! over the hierarchy that `las`'s own COPC reader reads from its file, every original index
//! exactly once, a damaged COPC file refused by name, and its PSNR falling as its threshold
//! grows.
//!
//! A peer that is not installed (`just peers`) fails its gate under `CI=true` (no silent skip)
//! and skips it elsewhere, saying why.

use std::path::{Path, PathBuf};
use std::process::Command;

use cloud::glam::DVec3;
use cloud::{Camera, Model};

fn methods_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../methods")
}

/// The built-in methods and the repository's methods folder's.
fn catalogue() -> registry::Catalogue {
    let mut catalogue = registry::Catalogue::builtin();
    catalogue
        .add_external(&methods_dir())
        .expect("the methods folder loads");
    catalogue
}

/// `Some(indices)` from `pointsight visible`, or `None` (skip) when `method` is a peer that is
/// not installed outside CI; any other failure fails the test.
fn visible(method: &str, dataset: &str, view: usize, sets: &[&str]) -> Option<Vec<u32>> {
    run_visible(method, dataset, view, sets).map(|(indices, _)| indices)
}

/// [`visible`] with the command's standard output.
fn run_visible(
    method: &str,
    dataset: &str,
    view: usize,
    sets: &[&str],
) -> Option<(Vec<u32>, String)> {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("v.txt");
    let view = view.to_string();
    let mut args = vec![
        "visible",
        "--dataset",
        dataset,
        "--view",
        &view,
        "--method",
        method,
        "--out",
        out.to_str().expect("utf-8 path"),
    ];
    for s in sets {
        args.extend(["--set", s]);
    }
    let run = Command::new(env!("CARGO_BIN_EXE_pointsight"))
        .args(&args)
        .env("POINTSIGHT_METHODS", methods_dir())
        .env("POINTSIGHT_DATA", "/nonexistent")
        .output()
        .expect("the pointsight binary runs");
    let err = String::from_utf8_lossy(&run.stderr);
    if !run.status.success() && err.contains("not installed") {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "peer {method} is not installed under CI=true (run `just peers`): {err}"
        );
        eprintln!("skipped: peer {method} is not installed (`just peers`): {err}");
        return None;
    }
    assert!(run.status.success(), "{method} {sets:?}: {err}");
    let indices = std::fs::read_to_string(&out)
        .expect("output file")
        .lines()
        .map(|l| l.parse().expect("an index"))
        .collect();
    Some((indices, String::from_utf8_lossy(&run.stdout).into_owned()))
}

fn jaccard(a: &[u32], b: &[u32]) -> f64 {
    let a: std::collections::BTreeSet<_> = a.iter().collect();
    let b: std::collections::BTreeSet<_> = b.iter().collect();
    let union = a.union(&b).count();
    if union == 0 {
        1.0
    } else {
        a.intersection(&b).count() as f64 / union as f64
    }
}

#[test]
fn every_peer_is_installed_under_ci() {
    let peers: Vec<(&str, &str, Result<(), String>)> = catalogue()
        .cards()
        .into_iter()
        .filter_map(|m| Some((m.name, m.peer_of?, m.availability())))
        .collect();
    let names: Vec<&str> = peers.iter().map(|p| p.0).collect();
    for expected in [
        "open3d-hpr",
        "cgal-hpr",
        "pcu-raycast",
        "vtk-zbuffer",
        "pcl-voxel",
        "py3dtiles-lod",
        "copc-lod",
    ] {
        assert!(
            names.contains(&expected),
            "{expected} among the peers {names:?}"
        );
    }
    let missing: Vec<String> = peers
        .iter()
        .filter_map(|(n, of, a)| {
            a.as_ref()
                .err()
                .map(|why| format!("{n} (peer of {of}): {why}"))
        })
        .collect();
    assert!(
        missing.is_empty() || std::env::var("CI").as_deref() != Ok("true"),
        "peers not installed under CI=true (run `just peers`):\n{}",
        missing.join("\n")
    );
    for m in &missing {
        eprintln!("not installed: {m}");
    }
}

#[test]
fn cgal_hpr_is_our_hpr() {
    for (dataset, views) in [
        ("sphere-20000", [0, 5, 11]),
        ("sphere-plane-24000", [0, 3, 9]),
    ] {
        for view in views {
            for gamma in ["2", "3"] {
                let set = format!("gamma={gamma}");
                let Some(peer) = visible("cgal-hpr", dataset, view, &[&set]) else {
                    return;
                };
                let ours = visible("hpr", dataset, view, &[&set]).expect("ours runs");
                assert!(peer.len() > 100, "{dataset} view {view}: {}", peer.len());
                assert_eq!(
                    peer, ours,
                    "{dataset} view {view} γ = {gamma}: CGAL's hull differs from ours"
                );
                eprintln!(
                    "cgal-hpr = hpr: {dataset} view {view} γ = {gamma}, {} points",
                    ours.len()
                );
            }
        }
    }
}

#[test]
fn pcu_raycast_agrees_with_our_raycast() {
    // The same primitive on both sides: our ray cast with oriented discs (`primitive=disc`,
    // the normals protocol 2 sends), point-cloud-utils' surfels with 128 triangles each (its
    // default 7 inscribes a heptagon in the circle). Measured on sphere-20000 at 320 x 240:
    // 0.9971 to 0.9995 (with subdivs=7: 0.73 to 0.83; against our default spheres: 0.73 to
    // 0.74, the other primitive).
    let mut worst = 1.0f64;
    for view in [0, 4, 9, 13] {
        for factor in ["1.0", "1.5"] {
            let radius = format!("radius_factor={factor}");
            let common = [&radius[..], "primitive=disc", "width=320", "height=240"];
            let peer_sets: Vec<&str> = common.iter().copied().chain(["subdivs=128"]).collect();
            let Some(peer) = visible("pcu-raycast", "sphere-20000", view, &peer_sets) else {
                return;
            };
            let ours = visible("raycast", "sphere-20000", view, &common).expect("ours runs");
            let j = jaccard(&peer, &ours);
            eprintln!(
                "pcu-raycast vs raycast (discs): view {view} radius_factor {factor}: Jaccard \
                 {j:.4} ({} vs {} points)",
                peer.len(),
                ours.len()
            );
            worst = worst.min(j);
        }
    }
    assert!(worst >= 0.99, "worst Jaccard {worst:.4} < 0.99");
}

#[test]
fn the_peers_that_build_per_cloud_report_the_build_apart() {
    // Embree's BVH and VTK's window come on the protocol's `built` line, and our ray caster's
    // k-d tree is timed alone, so that the peers table gives both builds apart from the views.
    for (method, sets) in [
        ("pcu-raycast", &["width=160", "height=120"][..]),
        ("vtk-zbuffer", &["width=160", "height=120"]),
        ("raycast", &["width=160", "height=120", "primitive=disc"]),
    ] {
        let Some((_, stdout)) = run_visible(method, "sphere-20000", 0, sets) else {
            continue;
        };
        let build: f64 = stdout
            .split_whitespace()
            .find_map(|w| w.strip_prefix("build_seconds="))
            .unwrap_or_else(|| panic!("{method} reports no build_seconds: {stdout}"))
            .parse()
            .expect("a number");
        assert!(build > 0.0 && build < 60.0, "{method}: build {build} s");
    }
}

/// `vtkSelectVisiblePoints`' documented rule (VTK's `vtkSelectVisiblePoints.cxx`), brute force
/// in f64: every point drawn as a square sprite of `size` pixels centred on its projection
/// (the pixels whose centres lie in the square: OpenGL's point rasterisation) into a z-buffer
/// of nearest depths; a point is kept when, moved toward the eye along the view axis by the
/// world tolerance (the adapter's `depth_tolerance` × the eye's distance to the cloud's mean),
/// it lies nearer than the buffer at the pixel the moved point projects to. Unlike our
/// `splat::sprite`, which clips a point whose projection is outside the image whole, this draws
/// the part of its sprite that is inside (the views here keep the cloud inside the image).
fn vtk_rule(points: &[DVec3], camera: &Camera, size: usize, depth_tolerance: f64) -> Vec<u32> {
    let Model::Pinhole { fx, fy, cx, cy } = *camera.model() else {
        panic!("pinhole cameras only");
    };
    let (w, h) = (camera.width as i64, camera.height as i64);
    let (fwd, right, down) = (camera.forward(), camera.right(), camera.down());
    let project = |p: DVec3| {
        let v = p - camera.eye;
        let z = v.dot(fwd);
        (cx + fx * v.dot(right) / z, cy + fy * v.dot(down) / z, z)
    };
    let centre = points.iter().copied().sum::<DVec3>() / points.len() as f64;
    let tolerance = depth_tolerance * (centre - camera.eye).length();
    let mut buffer = vec![f64::INFINITY; (w * h) as usize];
    let half = size as f64 / 2.0;
    for &p in points {
        let (x, y, z) = project(p);
        if z <= 0.0 {
            continue;
        }
        // Pixels i with i + 0.5 in [x - size/2, x + size/2).
        let (ax, ay) = (
            (x - half - 0.5).ceil() as i64,
            (y - half - 0.5).ceil() as i64,
        );
        for py in ay.max(0)..(ay + size as i64).min(h) {
            for px in ax.max(0)..(ax + size as i64).min(w) {
                let k = (py * w + px) as usize;
                buffer[k] = buffer[k].min(z);
            }
        }
    }
    (0..points.len() as u32)
        .filter(|&i| {
            let (x, y, z) = project(points[i as usize] - fwd * tolerance);
            let (px, py) = (x.floor() as i64, y.floor() as i64);
            z > 0.0
                && (0..w).contains(&px)
                && (0..h).contains(&py)
                && z < buffer[(py * w + px) as usize]
        })
        .collect()
}

#[test]
fn vtk_zbuffer_follows_its_rule_and_agrees_with_our_splat_offscreen() {
    // The render window VTK opens on a machine without a display is an offscreen one.
    let folder = methods_dir().join("vtk-zbuffer");
    let python = methods_dir().join("../.venv/bin/python");
    let window = Command::new(&python)
        .args(["zbuffer.py", "--window-class"])
        .current_dir(&folder)
        .env_remove("DISPLAY")
        .output();
    let installed = window.as_ref().is_ok_and(|o| o.status.success());
    if !installed {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "peer vtk-zbuffer is not installed under CI=true (run `just peers`): {window:?}"
        );
        eprintln!("skipped: peer vtk-zbuffer is not installed (`just peers`): {window:?}");
        return;
    }
    let class = String::from_utf8_lossy(&window.expect("ran").stdout)
        .trim()
        .to_owned();
    assert!(
        ["vtkEGLRenderWindow", "vtkOSOpenGLRenderWindow"].contains(&class.as_str()),
        "VTK opened {class:?}, not an offscreen EGL or OSMesa window"
    );
    let ds = harness::datasets::Datasets::default()
        .load("sphere-20000", Path::new("/nonexistent"))
        .expect("a synthetic dataset");
    let (mut worst_rule, mut worst_splat, mut worst_disc) = (1.0f64, 1.0f64, 1.0f64);
    for view in [0, 4, 9, 13] {
        for radius_px in [1, 2] {
            let size = format!("point_size={}", 2 * radius_px);
            let radius = format!("radius_px={radius_px}");
            let common = ["depth_tolerance=0.01", "width=320", "height=240"];
            let peer_sets: Vec<&str> = std::iter::once(&size[..]).chain(common).collect();
            let disc_sets: Vec<&str> = std::iter::once(&radius[..]).chain(common).collect();
            let our_sets: Vec<&str> = disc_sets.iter().copied().chain(["rule=sprite"]).collect();
            let Some(peer) = visible("vtk-zbuffer", "sphere-20000", view, &peer_sets) else {
                return;
            };
            let camera = ds.views[view].with_resolution(320, 240).expect("a camera");
            let rule = vtk_rule(&ds.cloud.positions, &camera, 2 * radius_px, 0.01);
            let ours = visible("splat", "sphere-20000", view, &our_sets).expect("ours runs");
            let disc = visible("splat", "sphere-20000", view, &disc_sets).expect("ours runs");
            let (jr, js, jd) = (
                jaccard(&peer, &rule),
                jaccard(&peer, &ours),
                jaccard(&peer, &disc),
            );
            eprintln!(
                "vtk-zbuffer: view {view} point_size {}: Jaccard {jr:.4} against its rule \
                 ({} vs {} points), {js:.4} against splat rule=sprite radius_px {radius_px} ({} \
                 points), {jd:.4} against the disc rule ({} points)",
                2 * radius_px,
                peer.len(),
                rule.len(),
                ours.len(),
                disc.len()
            );
            worst_rule = worst_rule.min(jr);
            worst_splat = worst_splat.min(js);
            worst_disc = worst_disc.min(jd);
        }
    }
    // VTK drives its rule exactly (measured 0.997 to 0.9997 with multisampling off; with VTK's
    // default 4 samples the resolved depth breaks it: 0.66 at one pixel).
    assert!(
        worst_rule >= 0.99,
        "worst Jaccard against VTK's rule {worst_rule:.4}"
    );
    // Against our splat at VTK's rule (rule=sprite, what the peers table pairs it with) the
    // issue asks for 0.9: measured 0.9979 to 0.9998 (VTK's 24-bit depth and f32 positions
    // against ours). Against our default disc rule, another selection (discs at the point's
    // pixel, a relative tolerance there), 0.72 to 0.80: a floor that catches a regression.
    assert!(
        worst_splat >= 0.99,
        "worst Jaccard against splat rule=sprite {worst_splat:.4} < 0.99"
    );
    assert!(
        worst_disc >= 0.7,
        "worst Jaccard against the disc rule {worst_disc:.4} < 0.7"
    );
}

/// Occupied voxels (unit leaf, 10³ block from the origin) that a brute-force voxel walk
/// (Amanatides & Woo, f64) from `eye` to each voxel's centre finds behind another occupied one.
fn brute_force_occluded(occupied: &[[i64; 3]], eye: [f64; 3]) -> Vec<[i64; 3]> {
    let set: std::collections::BTreeSet<[i64; 3]> = occupied.iter().copied().collect();
    let mut out = Vec::new();
    for v in occupied {
        let d: Vec<f64> = (0..3).map(|a| v[a] as f64 + 0.5 - eye[a]).collect();
        let mut ijk: Vec<i64> = eye.iter().map(|e| e.floor() as i64).collect();
        let step: Vec<i64> = d.iter().map(|&x| if x > 0.0 { 1 } else { -1 }).collect();
        let mut t_max: Vec<f64> = (0..3)
            .map(|a| {
                let boundary = (ijk[a] + i64::from(step[a] > 0)) as f64;
                if d[a] == 0.0 {
                    f64::INFINITY
                } else {
                    (boundary - eye[a]) / d[a]
                }
            })
            .collect();
        let t_delta: Vec<f64> = d.iter().map(|x| (1.0 / x).abs()).collect();
        for _ in 0..100 {
            let here = [ijk[0], ijk[1], ijk[2]];
            if here == *v {
                break;
            }
            if set.contains(&here) {
                out.push(*v);
                break;
            }
            let a = (0..3)
                .min_by(|&a, &b| t_max[a].total_cmp(&t_max[b]))
                .expect("three axes");
            ijk[a] += step[a];
            t_max[a] += t_delta[a];
        }
    }
    out.sort_unstable();
    out
}

#[test]
fn pcl_voxel_occlusion_against_a_brute_force_walk() {
    // A 10³ grid, 8 % of its voxels occupied (fixed LCG), one point at each occupied centre.
    let mut state = 3u64;
    let mut occupied = Vec::new();
    for i in 0..10 {
        for j in 0..10 {
            for k in 0..10 {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                if (state >> 33) % 100 < 8 {
                    occupied.push([i, j, k]);
                }
            }
        }
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let ply = dir.path().join("grid.ply");
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty double x\n\
         property double y\nproperty double z\nend_header\n",
        occupied.len()
    )
    .into_bytes();
    for v in &occupied {
        for c in v {
            bytes.extend_from_slice(&(*c as f64 + 0.5).to_le_bytes());
        }
    }
    std::fs::write(&ply, bytes).expect("write grid");
    // The gate's view: an eye in the all-negative octant (PCL's traversal enters through the
    // grid's min faces, where its rounding of the entry voxel, PCL #2046, errs least); the
    // other octants' agreement is printed: that is what PCL's users get.
    let eyes = [
        // Measured: Jaccard 0.796 (43 occluded by PCL, 54 by the walk); the floor catches a
        // regression, PCL's rounding is what its users get.
        ([-6.3, -4.1, -7.7], Some(0.75)),
        ([17.3, 14.1, -6.2], None),
        ([4.9, -9.1, 18.3], None),
    ];
    for (eye, gate) in eyes {
        let out = dir.path().join("v.txt");
        let eye_arg = format!("{},{},{}", eye[0], eye[1], eye[2]);
        let run = Command::new(env!("CARGO_BIN_EXE_pointsight"))
            .args([
                "visible",
                "--cloud",
                ply.to_str().expect("utf-8"),
                "--eye",
                &eye_arg,
                "--method",
                "pcl-voxel",
                "--set",
                "leaf_size=1",
                "--out",
                out.to_str().expect("utf-8"),
            ])
            .env("POINTSIGHT_METHODS", methods_dir())
            .env("POINTSIGHT_DATA", "/nonexistent")
            .output()
            .expect("the pointsight binary runs");
        let err = String::from_utf8_lossy(&run.stderr);
        if !run.status.success() && err.contains("not installed") {
            assert!(
                std::env::var("CI").as_deref() != Ok("true"),
                "peer pcl-voxel is not installed under CI=true (run `just peers`): {err}"
            );
            eprintln!("skipped: peer pcl-voxel is not installed (`just peers`): {err}");
            return;
        }
        assert!(run.status.success(), "pcl-voxel: {err}");
        let visible: std::collections::BTreeSet<usize> = std::fs::read_to_string(&out)
            .expect("output")
            .lines()
            .map(|l| l.parse().expect("an index"))
            .collect();
        let pcl: Vec<u32> = (0..occupied.len() as u32)
            .filter(|i| !visible.contains(&(*i as usize)))
            .collect();
        let brute: Vec<u32> = brute_force_occluded(&occupied, eye)
            .iter()
            .map(|v| occupied.iter().position(|o| o == v).expect("occupied") as u32)
            .collect();
        let j = jaccard(&pcl, &brute);
        eprintln!(
            "pcl-voxel vs brute-force walk, eye {eye:?}: {} occupied, {} occluded by PCL, {} by \
             the walk, Jaccard {j:.3}",
            occupied.len(),
            pcl.len(),
            brute.len()
        );
        assert!(brute.len() > 10, "the grid occludes something");
        if let Some(min) = gate {
            assert!(j >= min, "eye {eye:?}: Jaccard {j:.3} < {min}");
        }
    }
}

#[test]
fn py3dtiles_lod_selection_shrinks_as_the_view_recedes() {
    use cloud::glam::{DVec3, Vec2, Vec3};
    let method = catalogue().card("py3dtiles-lod").expect("in the catalogue");
    assert!(method.is_lod(), "an LOD method");
    assert_eq!(method.peer_of, Some("lod"));
    if let Err(why) = method.availability() {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "peer py3dtiles-lod is not installed under CI=true (run `just peers`): {why}"
        );
        eprintln!("skipped: peer py3dtiles-lod: {why}");
        return;
    }
    // A Fibonacci sphere of 20 000 points, as sphere-20000.
    let n = 20_000;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let positions: Vec<DVec3> = (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - y * y).sqrt();
            let t = golden * i as f64;
            DVec3::new(r * t.cos(), y, r * t.sin())
        })
        .collect();
    let normals: Vec<Vec3> = positions.iter().map(|p| p.as_vec3()).collect();
    let cloud = cloud::PointCloud {
        positions,
        colors: Some(vec![[200, 120, 40]; n]),
        ..Default::default()
    };
    let albedo = vec![Vec3::new(0.8, 0.5, 0.2); n];
    let uvs = vec![Vec2::ZERO; n];
    let texture = srn::texture::Texture::new(1, 1, vec![[0, 0, 0]]).expect("texture");
    let input = registry::lod::LodInput {
        cloud: &cloud,
        normals: &normals,
        albedo: &albedo,
        uvs: &uvs,
        texture: Some(&texture),
        radius: 0.01,
        seed: 0,
    };
    // Through the kernel, as the lod experiment runs it: built once (its own build seconds),
    // then one selection per view, each told its view's index.
    let views: Vec<registry::kernel::View> = [2.5, 5.0, 10.0, 20.0, 40.0]
        .into_iter()
        .enumerate()
        .map(|(index, distance)| registry::kernel::View {
            index,
            camera: Camera::new(
                DVec3::new(0.0, 0.0, distance),
                DVec3::ZERO,
                DVec3::Y,
                50.0,
                640,
                480,
            )
            .expect("camera"),
        })
        .collect();
    let settings = [registry::Setting::parse("sse_px=16")];
    let cell = registry::kernel::LodCell {
        method,
        settings: &settings,
        views: &views,
        repeats: 1,
        build_repeats: 1,
    };
    let mut counts = vec![0; views.len()];
    let built = registry::kernel::run_lod(&cell, &input, |_, v, selection| {
        let selection = selection.expect("a selection");
        assert!(selection.splats.iter().all(|s| s.radius >= 0.01));
        assert!(selection.timing.median >= 0.0);
        counts[v] = selection.splats.len();
    })
    .expect("py3dtiles builds a tileset");
    eprintln!(
        "py3dtiles-lod: {} tiles, {} bytes, built in {:.3} s (its own time)",
        built.size.nodes, built.size.bytes, built.timing.median
    );
    assert!(built.size.nodes > 1 && built.timing.median > 0.0);
    eprintln!("py3dtiles-lod: splats at distances 2.5, 5, 10, 20, 40: {counts:?}");
    assert!(counts.windows(2).all(|w| w[1] <= w[0]), "{counts:?}");
    assert!(counts[4] < counts[0], "{counts:?}");
}

// ---- copc-lod: copc_converter's COPC octree, selected per view ----

/// The COPC peer's program, or `None` (skip) when it is not installed outside CI.
fn copc_lod() -> Option<PathBuf> {
    let method = catalogue().card("copc-lod").expect("in the catalogue");
    assert!(method.is_lod(), "an LOD method");
    assert_eq!(method.peer_of, Some("lod"));
    if let Err(why) = method.availability() {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "peer copc-lod is not installed under CI=true (run `just peers`): {why}"
        );
        eprintln!("skipped: peer copc-lod: {why}");
        return None;
    }
    Some(methods_dir().join("../.tools/bin/copc-lod"))
}

/// A Fibonacci sphere of `n` points of radius `r` about `c`.
fn fibonacci_sphere(n: usize, r: f64, c: DVec3) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let s = (1.0 - y * y).sqrt();
            let t = golden * i as f64;
            c + r * DVec3::new(s * t.cos(), y, s * t.sin())
        })
        .collect()
}

/// A cloud whose octree is deeper in one corner: a unit sphere of 150,000 points and a
/// ball of radius 0.2 at (0.5, 0.5, 0.5) of 200,000 (copc_converter keeps up to 100,000 points
/// in a leaf: the octant with the ball splits further, the others stay leaves at level 1).
fn uneven_cloud() -> Vec<DVec3> {
    let mut p = fibonacci_sphere(150_000, 1.0, DVec3::ZERO);
    p.extend(fibonacci_sphere(200_000, 0.2, DVec3::splat(0.5)));
    p
}

/// The protocol's points file for `positions` (normals outward, a colour each).
fn write_points(path: &Path, positions: &[DVec3]) {
    let n = positions.len();
    let cloud = cloud::PointCloud {
        positions: positions.to_vec(),
        normals: Some(positions.iter().map(|p| p.normalize().as_vec3()).collect()),
        colors: Some((0..n).map(|i| [(i % 251) as u8, 120, 40]).collect()),
        ..Default::default()
    };
    cloud::io::ply_write::write_ply(path, &cloud).expect("the points file is written");
}

/// The peer's program speaking the protocol's LOD form, started by the test.
struct CopcSession {
    child: std::process::Child,
    stdin: Option<std::process::ChildStdin>,
    out: std::io::BufReader<std::process::ChildStdout>,
}

impl CopcSession {
    /// Starts `program` on the points file with `extra` arguments; returns it and its first
    /// line.
    fn start(
        program: &Path,
        points: &Path,
        radius: f64,
        spacing: f64,
        extra: &[&std::ffi::OsStr],
    ) -> (Self, serde_json::Value) {
        use std::process::Stdio;
        let mut child = Command::new(program)
            .arg("--points")
            .arg(points)
            .args(["--params", "{}", "--protocol", "2", "--normals", "dataset"])
            .args(["--spacing", &format!("{spacing:e}"), "--lod"])
            .args(["--radius", &format!("{radius:e}")])
            .args(extra)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("copc-lod starts");
        let stdin = child.stdin.take();
        let out = std::io::BufReader::new(child.stdout.take().expect("stdout"));
        let mut s = CopcSession { child, stdin, out };
        let first = s.line();
        (s, first)
    }

    fn line(&mut self) -> serde_json::Value {
        use std::io::BufRead;
        let mut line = String::new();
        self.out.read_line(&mut line).expect("a line");
        serde_json::from_str(&line).unwrap_or_else(|e| panic!("not JSON ({e}): {line:.300}"))
    }

    /// The answer for `camera` at `spacing_px`.
    fn ask(&mut self, view: usize, camera: &Camera, spacing_px: &str) -> serde_json::Value {
        use std::io::Write;
        let request = format!(
            "{{\"view\":{view},\"camera\":{},\"params\":{{\"spacing_px\":\"{spacing_px}\"}}}}\n",
            camera.to_json()
        );
        let stdin = self.stdin.as_mut().expect("input open");
        stdin.write_all(request.as_bytes()).expect("request sent");
        stdin.flush().expect("flushed");
        self.line()
    }
}

impl Drop for CopcSession {
    fn drop(&mut self) {
        // End of input means exit.
        drop(self.stdin.take());
        let _ = self.child.wait();
    }
}

/// An answer's indices and radii, as the program sent them.
fn indices_and_radii(a: &serde_json::Value) -> (Vec<u32>, Vec<f64>) {
    let visible = a["visible"]
        .as_array()
        .unwrap_or_else(|| panic!("{a:.300}"));
    let radius = a["radius"].as_array().expect("per-index radii");
    assert_eq!(visible.len(), radius.len());
    (
        visible
            .iter()
            .map(|v| v.as_u64().expect("index") as u32)
            .collect(),
        radius.iter().map(|r| r.as_f64().expect("radius")).collect(),
    )
}

/// A COPC voxel key: level, x, y, z.
type NodeKey = (i32, i32, i32, i32);

/// The COPC file as `las`'s own COPC reader (crates.io) sees it: the info VLR's octree, and
/// per hierarchy node its points' original indices (the Extra Bytes `index`) and positions.
struct CopcTruth {
    center: DVec3,
    halfsize: f64,
    spacing: f64,
    nodes: std::collections::HashMap<NodeKey, Vec<(u32, DVec3)>>,
}

impl CopcTruth {
    fn read(path: &Path) -> Self {
        let mut reader = las::CopcReader::from_path(path).expect("las reads the COPC file");
        let info = reader.header().copc_info_vlr().expect("a COPC info VLR");
        let entries: Vec<las::copc::Entry> = reader.hierarchy_entries().collect();
        let mut nodes = std::collections::HashMap::new();
        for e in entries {
            let points = reader.read_entry(&e).expect("the node decodes");
            let pts: Vec<(u32, DVec3)> = points
                .points()
                .map(|p| {
                    let p = p.expect("a point");
                    let i = u32::from_le_bytes(p.extra_bytes[..4].try_into().expect("index"));
                    (i, DVec3::new(p.x, p.y, p.z))
                })
                .collect();
            assert_eq!(pts.len(), e.point_count as usize);
            nodes.insert((e.key.l, e.key.x, e.key.y, e.key.z), pts);
        }
        CopcTruth {
            center: DVec3::new(info.center_x, info.center_y, info.center_z),
            halfsize: info.halfsize,
            spacing: info.spacing,
            nodes,
        }
    }

    fn bounds(&self, k: NodeKey) -> (DVec3, DVec3) {
        let side = 2.0 * self.halfsize / f64::from(1u32 << k.0);
        let lo = self.center - DVec3::splat(self.halfsize)
            + side * DVec3::new(f64::from(k.1), f64::from(k.2), f64::from(k.3));
        (lo, lo + DVec3::splat(side))
    }

    fn level_spacing(&self, l: i32) -> f64 {
        self.spacing / f64::from(1u32 << l)
    }
}

/// True when the box lies wholly outside one plane of the pinhole frustum (the eye's
/// z = 0 plane and the four planes through the image border).
fn culled(camera: &Camera, lo: DVec3, hi: DVec3) -> bool {
    let Model::Pinhole { fx, fy, cx, cy } = *camera.model() else {
        panic!("pinhole")
    };
    let (w, h) = (f64::from(camera.width), f64::from(camera.height));
    let corners: Vec<DVec3> = (0..8)
        .map(|k| {
            let p = DVec3::new(
                if k & 1 == 1 { hi.x } else { lo.x },
                if k & 2 == 2 { hi.y } else { lo.y },
                if k & 4 == 4 { hi.z } else { lo.z },
            ) - camera.eye;
            DVec3::new(
                p.dot(camera.right()),
                p.dot(camera.down()),
                p.dot(camera.forward()),
            )
        })
        .collect();
    // In front of the eye, u >= 0, u <= width, v >= 0, v <= height.
    let planes = [
        DVec3::Z,
        DVec3::new(fx, 0.0, cx),
        DVec3::new(-fx, 0.0, w - cx),
        DVec3::new(0.0, fy, cy),
        DVec3::new(0.0, -fy, h - cy),
    ];
    planes
        .iter()
        .any(|a| corners.iter().all(|c| a.dot(*c) < 0.0))
}

/// The brute-force selection: each node on its own, kept when it is not culled and no
/// ancestor is culled or has a projected spacing (at its nearest point to the eye) below the
/// threshold; then each kept point's expected radius: `R` scaled by the spacing of the
/// deepest kept node holding it over `S`, or `R` where no node exists below that one.
fn brute_force_selection(
    truth: &CopcTruth,
    camera: &Camera,
    threshold: f64,
    radius: f64,
    spacing: f64,
) -> Vec<(u32, f64)> {
    let Model::Pinhole { fx, fy, .. } = *camera.model() else {
        panic!("pinhole")
    };
    let projected = |k: NodeKey| {
        let (lo, hi) = truth.bounds(k);
        let d = (lo - camera.eye)
            .max(camera.eye - hi)
            .max(DVec3::ZERO)
            .length();
        if d > 0.0 {
            fx.max(fy) * truth.level_spacing(k.0) / d
        } else {
            f64::INFINITY
        }
    };
    let parent = |k: NodeKey| (k.0 - 1, k.1 >> 1, k.2 >> 1, k.3 >> 1);
    let kept: std::collections::HashSet<NodeKey> = truth
        .nodes
        .keys()
        .copied()
        .filter(|&k| {
            let (lo, hi) = truth.bounds(k);
            let mut ok = !culled(camera, lo, hi);
            let mut a = k;
            while ok && a.0 > 0 {
                a = parent(a);
                let (lo, hi) = truth.bounds(a);
                ok = !culled(camera, lo, hi) && projected(a) >= threshold;
            }
            ok
        })
        .collect();
    let key_at = |p: DVec3, l: i32| {
        let (lo, _) = truth.bounds((0, 0, 0, 0));
        let side = 2.0 * truth.halfsize / f64::from(1u32 << l);
        let c = ((p - lo) / side).floor();
        (l, c.x as i32, c.y as i32, c.z as i32)
    };
    let mut out = Vec::new();
    for &k in &kept {
        for &(i, p) in &truth.nodes[&k] {
            let deepest = (k.0..=30)
                .take_while(|&l| kept.contains(&key_at(p, l)))
                .last()
                .expect("its own node");
            let r = if truth.nodes.contains_key(&key_at(p, deepest + 1)) {
                radius.max(radius * truth.level_spacing(deepest) / spacing)
            } else {
                radius
            };
            out.push((i, r));
        }
    }
    out.sort_by_key(|&(i, _)| i);
    out
}

/// Whether `p` lies within a hair of a cell border of any level up to `max_level` (where a
/// floor and the program's midpoint comparison may place it on different sides).
fn near_a_cell_border(truth: &CopcTruth, p: DVec3, max_level: i32) -> bool {
    let (lo, _) = truth.bounds((0, 0, 0, 0));
    (0..=max_level).any(|l| {
        let side = 2.0 * truth.halfsize / f64::from(1u32 << l);
        let c = (p - lo) / side;
        [c.x, c.y, c.z].iter().any(|v| (v - v.round()).abs() < 1e-7)
    })
}

/// The COPC file copc-lod built from [`uneven_cloud`] (built once for the tests of this
/// binary), with its points file: (folder, points file, COPC file, first line), or `None`
/// (skip).
fn built_copc() -> Option<&'static (tempfile::TempDir, PathBuf, PathBuf, serde_json::Value)> {
    static BUILT: std::sync::OnceLock<
        Option<(tempfile::TempDir, PathBuf, PathBuf, serde_json::Value)>,
    > = std::sync::OnceLock::new();
    BUILT
        .get_or_init(|| {
            let program = copc_lod()?;
            let dir = tempfile::tempdir().expect("temp dir");
            let points = dir.path().join("points.ply");
            write_points(&points, &uneven_cloud());
            let copc = dir.path().join("uneven.copc.laz");
            let (_, first) = CopcSession::start(
                &program,
                &points,
                COPC_RADIUS,
                COPC_SPACING,
                &[std::ffi::OsStr::new("--save-copc"), copc.as_os_str()],
            );
            Some((dir, points, copc, first))
        })
        .as_ref()
}

/// The full-detail radius and density spacing the COPC tests send.
const COPC_RADIUS: f64 = 0.006;
const COPC_SPACING: f64 = 0.004;

#[test]
fn copc_lod_selection_equals_a_brute_force_over_its_hierarchy() {
    let Some((_dir, points, copc, first)) = built_copc() else {
        return;
    };
    let program = copc_lod().expect("installed");
    assert_eq!(first["built"], true, "{first}");
    let truth = CopcTruth::read(copc);
    let n = 350_000;
    assert_eq!(first["nodes"].as_u64(), Some(truth.nodes.len() as u64));
    assert_eq!(
        first["bytes"].as_u64(),
        Some(std::fs::metadata(copc).expect("the COPC file").len())
    );
    let depth = truth.nodes.keys().map(|k| k.0).max().expect("nodes");
    eprintln!(
        "copc-lod: {} nodes, depth {depth}, root spacing {:.5}, built in {} s",
        truth.nodes.len(),
        truth.spacing,
        first["seconds"]
    );
    // Leaves at several levels: the ball's octant splits deeper than the others.
    assert!(depth >= 2, "depth {depth}");
    assert!(
        truth.nodes.keys().any(|k| k.0 == 1
            && !truth
                .nodes
                .keys()
                .any(|c| c.0 == 2 && (c.1 >> 1) == k.1 && (c.2 >> 1) == k.2 && (c.3 >> 1) == k.3)),
        "a leaf at level 1"
    );
    // Every original index exactly once in the file, as las reads it.
    let mut all: Vec<u32> = truth
        .nodes
        .values()
        .flat_map(|v| v.iter().map(|p| p.0))
        .collect();
    all.sort_unstable();
    assert_eq!(all, (0..n as u32).collect::<Vec<_>>());
    // Through the protocol, from the file it built (opened as a given COPC file).
    let (mut s, again) = CopcSession::start(
        &program,
        points,
        COPC_RADIUS,
        COPC_SPACING,
        &[std::ffi::OsStr::new("--copc"), copc.as_os_str()],
    );
    assert_eq!(again["nodes"], first["nodes"]);
    let file_bytes = first["bytes"].as_u64().expect("bytes");
    let cameras = [
        // Whole cloud in view, far and near.
        (DVec3::new(0.0, 0.0, 8.0), DVec3::ZERO, 50.0),
        (DVec3::new(2.0, 1.5, 2.0), DVec3::ZERO, 50.0),
        // Close to the ball.
        (DVec3::new(0.9, 0.8, 1.1), DVec3::splat(0.5), 50.0),
        // A narrow view along x through the ball: most nodes outside the frustum.
        (DVec3::new(4.0, 0.5, 0.5), DVec3::new(0.9, 0.5, 0.5), 8.0),
        // Inside the root cube, looking out.
        (DVec3::new(0.1, 0.0, 0.0), DVec3::new(1.0, 0.2, 0.0), 50.0),
    ];
    let positions: std::collections::HashMap<u32, DVec3> =
        truth.nodes.values().flatten().copied().collect();
    let mut tolerated = 0usize;
    let mut compared = 0usize;
    let thresholds = [
        "0", "0.25", "0.5", "1", "1.5", "2", "3", "4", "6", "8", "12", "16", "1000",
    ];
    for (v, &(eye, target, fov)) in cameras.iter().enumerate() {
        let camera = Camera::new(eye, target, DVec3::Y, fov, 640, 480).expect("camera");
        let mut counts = Vec::new();
        for t in thresholds {
            let answer = s.ask(v, &camera, t);
            let (indices, radii) = indices_and_radii(&answer);
            let threshold: f64 = t.parse().expect("threshold");
            let expected =
                brute_force_selection(&truth, &camera, threshold, COPC_RADIUS, COPC_SPACING);
            let mut got: Vec<(u32, f64)> = indices.into_iter().zip(radii).collect();
            got.sort_by_key(|&(i, _)| i);
            let got_set: Vec<u32> = got.iter().map(|g| g.0).collect();
            let expected_set: Vec<u32> = expected.iter().map(|e| e.0).collect();
            assert_eq!(got_set.len(), expected_set.len(), "view {v} threshold {t}");
            assert!(
                got_set == expected_set,
                "view {v} threshold {t}: other indices"
            );
            for (g, e) in got.iter().zip(&expected) {
                compared += 1;
                if (g.1 - e.1).abs() > 1e-6 * e.1 {
                    assert!(
                        near_a_cell_border(&truth, positions[&g.0], depth),
                        "view {v} threshold {t}: point {} radius {} expected {}",
                        g.0,
                        g.1,
                        e.1
                    );
                    tolerated += 1;
                }
            }
            // The bytes read: the selected nodes' chunks, within the file.
            let read = answer["bytes_read"].as_u64().expect("bytes_read");
            assert!(read <= file_bytes && (read > 0) != got_set.is_empty());
            assert!(answer["seconds"].as_f64().is_some_and(|t| t >= 0.0));
            counts.push(got_set.len());
        }
        eprintln!("copc-lod: view {v}: points at {thresholds:?} px: {counts:?}");
        // Coarser thresholds select fewer points, and the finest every node in view.
        assert!(counts.windows(2).all(|w| w[1] <= w[0]), "{counts:?}");
        if v == 0 {
            assert_eq!(counts[0], n, "threshold 0 from afar: every point");
            // The root alone: one point per cell of its 128³ grid (about a fifth here).
            assert!(counts[thresholds.len() - 1] < n / 4, "{counts:?}");
        }
    }
    eprintln!("copc-lod: {tolerated} of {compared} radii differ on a cell border");
    assert!(tolerated * 1000 <= compared, "{tolerated} of {compared}");
}

#[test]
fn copc_lod_refuses_a_damaged_copc_file_naming_it() {
    let Some((dir, points, copc, _)) = built_copc() else {
        return;
    };
    let program = copc_lod().expect("installed");
    let bytes = std::fs::read(copc).expect("the COPC file");
    // The hierarchy's root page, from the COPC info VLR (the first VLR, at 375 + 54).
    let info = 375 + 54;
    let word = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
    let (page, page_size) = (word(info + 40) as usize, word(info + 48) as usize);
    assert!(page_size >= 32 && page + page_size <= bytes.len());
    let mut damaged: Vec<(&str, Vec<u8>, &str)> = Vec::new();
    // Truncated: the hierarchy (written last) is cut off.
    damaged.push((
        "truncated",
        bytes[..bytes.len() - 40].to_vec(),
        "past the end",
    ));
    // A node's point count flipped: the counts no longer sum to the header's.
    let mut b = bytes.clone();
    b[page + 32 + 28] ^= 0x5a;
    damaged.push(("count", b, ""));
    // A node's chunk offset sent far away.
    let mut b = bytes.clone();
    b[page + 32 + 16 + 6] ^= 0xff;
    damaged.push(("offset", b, "not within the points"));
    // A node's level flipped: outside the octree or without a parent.
    let mut b = bytes.clone();
    b[page + 32] ^= 0x07;
    damaged.push(("key", b, ""));
    // The chunk of the first node garbled.
    let mut b = bytes.clone();
    let first_chunk = word(page + 16) as usize;
    for x in &mut b[first_chunk + 40..first_chunk + 400] {
        *x = x.wrapping_mul(31).wrapping_add(7);
    }
    damaged.push(("chunk", b, ""));
    for (what, data, says) in damaged {
        let path = dir.path().join(format!("damaged-{what}.copc.laz"));
        std::fs::write(&path, data).expect("written");
        let (mut s, first) = CopcSession::start(
            &program,
            points,
            COPC_RADIUS,
            COPC_SPACING,
            &[std::ffi::OsStr::new("--copc"), path.as_os_str()],
        );
        let msg = first["error"]
            .as_str()
            .unwrap_or_else(|| panic!("{what}: no error: {first:.300}"));
        eprintln!("copc-lod, {what}: {msg}");
        assert!(msg.contains(path.to_str().expect("utf-8")), "{what}: {msg}");
        assert!(msg.contains(says), "{what}: {msg}");
        let status = s.child.wait().expect("it exits");
        assert!(!status.success(), "{what}");
    }
}

#[test]
fn copc_lod_through_the_kernel_psnr_falls_as_the_threshold_grows() {
    use cloud::glam::{Vec2, Vec3};
    if copc_lod().is_none() {
        return;
    }
    let method = catalogue().card("copc-lod").expect("in the catalogue");
    let positions = uneven_cloud();
    let n = positions.len();
    let normals: Vec<Vec3> = positions.iter().map(|p| p.normalize().as_vec3()).collect();
    let cloud = cloud::PointCloud {
        positions,
        colors: Some((0..n).map(|i| [(i % 251) as u8, 120, 40]).collect()),
        ..Default::default()
    };
    let albedo: Vec<Vec3> = (0..n)
        .map(|i| Vec3::new((i % 251) as f32 / 255.0, 0.47, 0.16))
        .collect();
    let uvs = vec![Vec2::ZERO; n];
    let radius =
        1.5 * cloud::spacing::density_spacing(&cloud.positions, 8, 20_000, 1).expect("spacing");
    let input = registry::lod::LodInput {
        cloud: &cloud,
        normals: &normals,
        albedo: &albedo,
        uvs: &uvs,
        texture: None,
        radius,
        seed: 0,
    };
    let views: Vec<registry::kernel::View> = [2.5, 5.0]
        .into_iter()
        .enumerate()
        .map(|(index, d)| registry::kernel::View {
            index,
            camera: Camera::new(
                DVec3::new(0.3, 0.4, d),
                DVec3::ZERO,
                DVec3::Y,
                50.0,
                320,
                240,
            )
            .expect("camera"),
        })
        .collect();
    let thresholds = ["0.5", "1", "2", "4", "1000"];
    let settings: Vec<registry::Setting> = thresholds
        .iter()
        .map(|t| registry::Setting::parse(&format!("spacing_px={t}")))
        .collect();
    let cell = registry::kernel::LodCell {
        method,
        settings: &settings,
        views: &views,
        repeats: 1,
        build_repeats: 1,
    };
    let params = splat::render::RenderParams::default();
    let full: Vec<splat::render::Splat> = (0..n).map(|i| input.point_splat(i, radius)).collect();
    let references: Vec<splat::render::Image> = views
        .iter()
        .map(|v| splat::render::render(&full, &v.camera, &params))
        .collect();
    let mut scores = vec![vec![(0usize, 0.0f64, 0u64); thresholds.len()]; views.len()];
    let built = registry::kernel::run_lod(&cell, &input, |k, v, selection| {
        let s = selection.expect("a selection");
        let img = splat::render::render(&s.splats, &views[v].camera, &params);
        let psnr = registry::scoring::psnr(&references[v], &img);
        let reads = s
            .reads
            .expect("its bytes read, carried as a file selection's");
        scores[v][k] = (s.splats.len(), psnr, reads.bytes_read);
    })
    .expect("copc_converter builds");
    eprintln!(
        "copc-lod: {} nodes, {} bytes, built in {:.3} s (copc_converter's wall time)",
        built.size.nodes, built.size.bytes, built.timing.median
    );
    assert!(built.size.nodes > 1 && built.timing.median > 0.0);
    for (v, row) in scores.iter().enumerate() {
        eprintln!("copc-lod: view {v}: (splats, PSNR dB, bytes read) at {thresholds:?}: {row:?}");
        assert!(
            row.windows(2).all(|w| w[1].0 <= w[0].0 && w[1].2 <= w[0].2),
            "{row:?}"
        );
        assert!(row.windows(2).all(|w| w[1].1 <= w[0].1 + 0.5), "{row:?}");
        let (finest, coarsest) = (row[0], row[thresholds.len() - 1]);
        assert!(finest.1 > coarsest.1 + 3.0, "{row:?}");
        assert!(coarsest.0 * 4 < finest.0, "{row:?}");
    }
}
