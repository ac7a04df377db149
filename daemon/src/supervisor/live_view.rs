//! The supervisor's side of the live view: what it hands the publisher beyond what it
//! records (the state, loop timing, the scene again for clients that joined late), always
//! through the tap's queue that drops rather than blocks.

use super::*;

use crate::live::messages::{LiveState, LoopTiming};

impl Supervisor {
    /// The live view, if it is on and someone is subscribed to `topic`.
    pub(super) fn live_for(&self, topic: LiveTopic) -> Option<&LiveTap> {
        self.links.live.as_ref().filter(|l| l.wants(topic))
    }

    pub(super) fn offer_json<T: serde::Serialize>(
        &self,
        live: &LiveTap,
        topic: LiveTopic,
        t_s: f64,
        v: &T,
    ) {
        match serde_json::to_vec(v) {
            Ok(json) => live.offer(LiveMsg::Json {
                topic,
                log_time_ns: live.epoch().ns(t_s),
                json,
            }),
            Err(e) => tracing::error!("cannot serialize a {} message: {e}", topic.name()),
        }
    }

    /// Publish `v` live on `topic`, if anyone is subscribed.
    pub(super) fn live_json<T: serde::Serialize>(&self, topic: LiveTopic, t_s: f64, v: &T) {
        if let Some(live) = self.live_for(topic) {
            self.offer_json(live, topic, t_s, v);
        }
    }

    /// A tactile frame for the live view (raw, and band-passed by the publisher).
    pub(super) fn live_tactile(&self, sample: &crate::recording::messages::TactileSample) {
        if let Some(live) = self.live_for(LiveTopic::Recorded(Topic::Tactile)) {
            live.offer(LiveMsg::Tactile {
                log_time_ns: live.epoch().ns(sample.t_s),
                sample: sample.clone(),
            });
        }
    }

    /// The trial's pulse period as the tracker last reported it (`None`: no trial).
    pub(super) fn live_period(&self, period_s: Option<f64>) {
        if let Some(live) = self.links.live.as_ref() {
            live.offer(LiveMsg::Period(period_s));
        }
    }

    /// The operating state on `/state`.
    pub(super) fn live_state(&self, t_s: f64) {
        if self.live_for(LiveTopic::State).is_none() {
            return;
        }
        let trial = self.trial.as_ref();
        let msg = LiveState {
            t_s,
            state: self.state.as_str().to_string(),
            fault: self.fault.as_ref().map(|(f, _)| match &self.fault_detail {
                Some(d) => format!("{}: {d}", f.describe()),
                None => f.describe(),
            }),
            trial: trial.map(|t| t.id.clone()),
            seeds: trial.map(|t| t.seeds()).unwrap_or(0),
            located: trial.map(|t| t.located.len()).unwrap_or(0),
            followed_m: trial.map(|t| t.followed_m()).unwrap_or(0.0),
        };
        self.live_json(LiveTopic::State, t_s, &msg);
    }

    /// Four times a second: the state, the loop's timing and, every fourth beat, the
    /// artery scene again (a client that connects mid-trial sees it without waiting for the
    /// next located point).
    pub(super) fn live_beat(&mut self, status: &ControlStatus) {
        let Some(dropped) = self.links.live.as_ref().map(LiveTap::dropped) else {
            return;
        };
        let t = status.t_s;
        self.live_beats += 1;
        // Beats are 250 ms apart: a line every 40 beats (10 s) at most.
        if dropped > self.live_dropped_logged && self.live_beats.is_multiple_of(40) {
            tracing::warn!(
                "live view: {dropped} messages dropped so far ({} new): its publisher fell behind",
                dropped - self.live_dropped_logged
            );
            self.live_dropped_logged = dropped;
        }
        self.live_state(t);
        if self.live_for(LiveTopic::Loop).is_some() {
            let timing = LoopTiming {
                t_s: t,
                cycles: status.cycle,
                overruns: status.overruns,
                loop_dropped: status.dropped,
                live_dropped: dropped,
                period_p50_us: self.timing.map(|p| p.p50_us),
                period_p99_us: self.timing.map(|p| p.p99_us),
                period_max_us: self.timing.map(|p| p.max_us),
            };
            self.live_json(LiveTopic::Loop, t, &timing);
        }
        if self.live_beats.is_multiple_of(4) {
            self.live_scene(t);
        }
    }

    /// The whole artery scene, live only.
    pub(super) fn live_scene(&self, t: f64) {
        let Some(live) = self.live_for(LiveTopic::Recorded(Topic::Artery)) else {
            return;
        };
        let epoch = live.epoch();
        let mut entities: Vec<fox::SceneEntity> =
            self.true_path_entity(epoch, t).into_iter().collect();
        entities.extend(self.located_entity(epoch, t));
        entities.push(self.ahead_entity(epoch, t));
        let update = fox::SceneUpdate {
            deletions: Vec::new(),
            entities,
        };
        self.offer_json(live, LiveTopic::Recorded(Topic::Artery), t, &update);
    }

    /// The live view in `status`: where to connect and what it dropped.
    pub(super) fn live_status(&self) -> Value {
        match self.links.live.as_ref() {
            Some(l) => json!({"enabled": true, "url": l.url(), "dropped": l.dropped(),
                "log_lines_dropped": crate::service::log_forward::dropped()}),
            None => json!({"enabled": false}),
        }
    }
}
