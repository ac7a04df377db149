//! Steps a console command waits through, shared by `demo` and `search`: a state reached,
//! a mark's result, a search's end. Each fails on a fault event, naming it.

use std::time::{Duration, Instant};

use serde_json::{Value, json};

use crate::cli::console::describe_event;
use crate::cli::stdout::outln;
use crate::console::client::Client;

const T: Duration = Duration::from_secs(30);

/// Wait until the daemon reports `want` (polling status: state events queued before the
/// last request would be stale), failing on a fault.
pub fn wait_state(c: &mut Client, want: &str) -> Result<(), String> {
    let deadline = Instant::now() + Duration::from_secs(300);
    loop {
        while let Some(e) = c
            .next_event(Duration::from_millis(50))
            .map_err(|e| e.to_string())?
        {
            if e["event"] == "fault" {
                return Err(describe_event(&e).unwrap_or_default());
            }
        }
        let s = c.call("status", json!({}), T).map_err(|e| e.to_string())?;
        if s["state"] == want {
            return Ok(());
        }
        if Instant::now() > deadline {
            return Err(format!("still {} after 5 minutes", s["state"]));
        }
    }
}

/// Wait for a mark's result: true if the pulse was located. Every detection but a miss is
/// handed to `say` as one line.
pub fn wait_mark(c: &mut Client, say: &mut dyn FnMut(String)) -> Result<bool, String> {
    loop {
        let Some(e) = c
            .next_event(Duration::from_secs(300))
            .map_err(|e| e.to_string())?
        else {
            return Err("the mark gave no result".into());
        };
        match (e["event"].as_str(), e["kind"].as_str()) {
            (Some("detection"), Some("missed")) => return Ok(false),
            (Some("detection"), kind) => {
                if let Some(l) = describe_event(&e) {
                    say(l);
                }
                if kind == Some("located") {
                    return Ok(true);
                }
            }
            (Some("fault"), _) => return Err(describe_event(&e).unwrap_or_default()),
            _ => {}
        }
    }
}

/// Follow a search (the `search` stream) to its end, handing each event to `say` (as the
/// event and its line for people); returns the `finished` event.
pub fn follow_search(c: &mut Client, say: &mut dyn FnMut(&Value, String)) -> Result<Value, String> {
    loop {
        let Some(e) = c
            .next_event(Duration::from_secs(600))
            .map_err(|e| e.to_string())?
        else {
            return Err("no word from the search for 10 minutes".into());
        };
        if e["event"] == "fault" {
            return Err(describe_event(&e).unwrap_or_else(|| "the daemon faulted".into()));
        }
        if e["event"] != "search" {
            continue;
        }
        say(&e, describe_event(&e).unwrap_or_default());
        if e["kind"] == "finished" {
            return Ok(e);
        }
    }
}

/// Follow a track to its trial's end, handing every detection event to `on_detection`:
/// `Ok(summary)` at the end, `Err(event)` when a fault ended it.
pub fn follow_track(
    c: &mut Client,
    on_detection: &mut dyn FnMut(&Value),
) -> Result<Result<Value, Value>, String> {
    loop {
        let Some(e) = c
            .next_event(Duration::from_secs(600))
            .map_err(|e| e.to_string())?
        else {
            return Err("no progress from the track for 10 minutes".into());
        };
        match e["event"].as_str() {
            Some("trial") if e["phase"] == "ended" => return Ok(Ok(e["summary"].clone())),
            Some("fault") => return Ok(Err(e)),
            Some("detection") => on_detection(&e),
            _ => {}
        }
    }
}

/// Say that the daemon refused `command`'s request: its reply as it is (`raw`, on stdout),
/// else one line on stderr.
pub fn report_refusal(command: &str, reply: &Value, raw: bool) {
    if raw {
        outln!("{reply}");
    } else {
        eprintln!(
            "{command}: refused: {} [{}]",
            reply["reason"].as_str().unwrap_or("?"),
            reply["error"].as_str().unwrap_or("?")
        );
    }
}
