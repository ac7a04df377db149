//! The `search` verb's arguments: the region's corners in metres (`x0_m`, `z0_m`, `x1_m`,
//! `z1_m`, tissue frame, in any order), an optional `method` (`search`, the default, or
//! `raster`) and an optional `heading_rad` (the expected course, from `+x`), checked for type
//! and range.

use serde_json::Value;

use super::{Args, ErrorCode, ParseLimits, RequestError, Verb, err};
use control::frames::SurfacePoint;
use control::search::{Region, SearchMethod};

pub(super) fn parse(args: &mut Args, limits: &ParseLimits) -> Result<Verb, RequestError> {
    let mut corner = |name: &str| -> Result<f64, RequestError> {
        let v = args.number(name, None)?;
        if v.abs() > limits.max_coordinate_m {
            return Err(err(
                Some(args.id),
                ErrorCode::OutOfRange,
                format!("`{name}` = {v} m is beyond ±{} m", limits.max_coordinate_m),
            ));
        }
        Ok(v)
    };
    let (x0, z0, x1, z1) = (
        corner("x0_m")?,
        corner("z0_m")?,
        corner("x1_m")?,
        corner("z1_m")?,
    );
    let region = Region::new(SurfacePoint::new(x0, z0), SurfacePoint::new(x1, z1))
        .map_err(|e| err(Some(args.id), ErrorCode::OutOfRange, e.to_string()))?;
    let method = match args.obj.remove("method") {
        None | Some(Value::Null) => SearchMethod::Search,
        Some(Value::String(m)) => SearchMethod::parse(&m).ok_or_else(|| {
            err(
                Some(args.id),
                ErrorCode::BadArgument,
                format!("unknown search method {m:?} (known: search, raster)"),
            )
        })?,
        Some(other) => {
            return Err(err(
                Some(args.id),
                ErrorCode::BadArgument,
                format!("`method` must be a string, got {other}"),
            ));
        }
    };
    let heading_rad = args.optional_number("heading_rad")?;
    if let Some(h) = heading_rad
        && h.abs() > control::search::line_map::MAX_HEADING_RAD
    {
        return Err(err(
            Some(args.id),
            ErrorCode::OutOfRange,
            format!(
                "`heading_rad` = {h} must lie within ±{:.4} rad (80 degrees) of x: the array follows only an artery that crosses it",
                control::search::line_map::MAX_HEADING_RAD
            ),
        ));
    }
    Ok(Verb::Search {
        region,
        method,
        heading_rad,
    })
}
