//! Accuracy gates of the peers (`methods/*/method.toml` with `peer_of`), each run through
//! `pointsight visible --method NAME` beside the family of ours it pairs with, on small
//! synthetic clouds: CGAL's HPR set identical to our `hpr` at the same γ; point-cloud-utils'
//! ray cast against our `raycast` with discs at equal radius (Jaccard ≥ 0.99); VTK's z-buffer
//! selection (in an offscreen EGL or OSMesa window) against a brute force of its own rule
//! (Jaccard ≥ 0.99) and beside our `splat`, on sphere-20000; PCL's occluded voxels against a
//! brute-force voxel walk on a 10³ grid; the py3dtiles LOD peer's selection shrinking as the
//! view recedes.
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
    registry::register_external(&methods_dir()).expect("the methods folder loads");
    let peers: Vec<(&str, &str, Result<(), String>)> = registry::cards()
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
    let ds = harness::datasets::load("sphere-20000", Path::new("/nonexistent"))
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
    registry::register_external(&methods_dir()).expect("the methods folder loads");
    let method = registry::card("py3dtiles-lod").expect("registered");
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
