//! Print points along a scene's artery path: `path_points SCENE S1 S2 ...` (arc lengths, m).
fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let name = args.next().ok_or("usage: path_points SCENE S...")?;
    let scene = pulsetrack_sim::scene::load(&name, None).map_err(|e| e.to_string())?;
    let path = pulsetrack_sim::scene::ArteryPath::from_spec(&scene.artery.path)
        .map_err(|e| e.to_string())?;
    for p in scene.placements {
        let n = path.nearest(p);
        println!(
            "placement ({:.4}, {:.4}) at s = {:.4} m, heading {:.1} deg",
            p.x_m,
            p.z_m,
            n.s_m,
            n.heading_rad.to_degrees()
        );
    }
    for a in args {
        let s: f64 = a.parse().map_err(|e| format!("{a}: {e}"))?;
        let (p, h) = path.at(s);
        println!(
            "s = {s:.4}: (x_m: {:.4}, z_m: {:.4}), heading {:.1} deg",
            p.x_m,
            p.z_m,
            h.to_degrees()
        );
    }
    Ok(())
}
