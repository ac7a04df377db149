//! The shipped Foxglove layout (`docs/foxglove/pulsetrack-layout.json`), embedded so that
//! `pulsetrack demo` can write it beside its recording wherever it runs.

pub const LAYOUT: &str = include_str!("../../../docs/foxglove/pulsetrack-layout.json");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::live::topics::LiveTopic;
    use serde_json::Value;

    /// Every message path a panel reads (`/topic.field[...]`) and every topic it names.
    fn references(v: &Value, out: &mut Vec<String>) {
        match v {
            Value::Object(o) => {
                for (k, x) in o {
                    match (k.as_str(), x) {
                        ("value" | "topicPath" | "topicToRender", Value::String(s)) => {
                            out.push(s.clone())
                        }
                        ("topics", Value::Object(t)) => out.extend(t.keys().cloned()),
                        _ => references(x, out),
                    }
                }
            }
            Value::Array(a) => a.iter().for_each(|x| references(x, out)),
            _ => {}
        }
    }

    #[test]
    fn every_panel_reads_a_live_channel_and_a_field_its_schema_has() {
        let layout: Value = serde_json::from_str(LAYOUT).expect("the layout is JSON");
        let mut refs = Vec::new();
        references(&layout["configById"], &mut refs);
        assert!(refs.len() >= 8, "{refs:?}");
        for r in &refs {
            let (topic, field) = match r.split_once('.') {
                Some((t, f)) => (t, Some(f)),
                None => (r.as_str(), None),
            };
            let t = LiveTopic::ALL
                .iter()
                .find(|t| t.name() == topic)
                .unwrap_or_else(|| panic!("{r}: {topic} is not a live channel"));
            if let Some(f) = field {
                let name = f.split(['[', '.']).next().unwrap_or(f);
                let schema: Value = serde_json::from_str(t.schema()).expect("schema");
                assert!(
                    schema["properties"].get(name).is_some(),
                    "{r}: {} has no field {name}",
                    t.schema_name()
                );
            }
        }
        // The panels the issue asks for, and the layout tree names only configured panels.
        let ids: Vec<&String> = layout["configById"]
            .as_object()
            .expect("configById")
            .keys()
            .collect();
        for kind in ["3D!", "Plot!", "StateTransitions!", "RosOut!"] {
            assert!(ids.iter().any(|i| i.starts_with(kind)), "no {kind} panel");
        }
        let mut leaves = Vec::new();
        fn walk<'a>(v: &'a Value, out: &mut Vec<&'a str>) {
            match v {
                Value::String(s) => out.push(s),
                Value::Object(o) => {
                    for k in ["first", "second"] {
                        if let Some(x) = o.get(k) {
                            walk(x, out);
                        }
                    }
                }
                _ => {}
            }
        }
        walk(&layout["layout"], &mut leaves);
        assert_eq!(leaves.len(), ids.len());
        for l in leaves {
            assert!(ids.iter().any(|i| *i == l), "{l} has no config");
        }
    }
}
