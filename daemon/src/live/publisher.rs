//! The publisher thread: takes what the supervisor queued and logs it on the live channels;
//! band-passes the tactile frames and measures the pulse on the way. It runs at normal
//! priority beside the recorder, never on the 1 kHz loop, and the server's logging never
//! blocks (each client has its own lossy backlog).

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, RecvTimeoutError};
use foxglove::{ChannelBuilder, Context, FoxgloveError, PartialMetadata, RawChannel, Schema};

use crate::live::bandpass::LiveBandPass;
use crate::live::tap::{LiveCounters, LiveMsg};
use crate::live::topics::LiveTopic;
use crate::recording::topics::Topic;
use crate::recording::trial_file::Epoch;

/// How often the "someone is subscribed" mask is refreshed.
const WANTED_REFRESH: Duration = Duration::from_millis(100);

/// The pulse is published this many times a second.
const PULSE_RATE_HZ: f64 = 10.0;

/// The live channels on `ctx`, one per [`LiveTopic`], in [`LiveTopic::ALL`] order.
pub fn channels(ctx: &Arc<Context>) -> Result<Vec<Arc<RawChannel>>, FoxgloveError> {
    LiveTopic::ALL
        .iter()
        .map(|t| {
            ChannelBuilder::new(t.name())
                .message_encoding("json")
                .schema(Schema::new(
                    t.schema_name(),
                    "jsonschema",
                    t.schema().as_bytes().to_vec(),
                ))
                .context(ctx)
                .build_raw()
        })
        .collect()
}

pub struct Publisher {
    channels: Vec<Arc<RawChannel>>,
    counters: Arc<LiveCounters>,
    bandpass: Option<LiveBandPass>,
    epoch: Epoch,
    frames_per_pulse: u64,
    frames_since_pulse: u64,
    period_s: Option<f64>,
    last_refresh: Instant,
}

impl std::fmt::Debug for Publisher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Publisher")
            .field("channels", &self.channels.len())
            .finish()
    }
}

impl Publisher {
    /// `bandpass`: `None` publishes the raw frames only. `sample_rate_hz`: the array's.
    pub fn new(
        channels: Vec<Arc<RawChannel>>,
        counters: Arc<LiveCounters>,
        bandpass: Option<LiveBandPass>,
        sample_rate_hz: f64,
        epoch: Epoch,
    ) -> Self {
        Self {
            channels,
            counters,
            bandpass,
            epoch,
            frames_per_pulse: (sample_rate_hz / PULSE_RATE_HZ).round().max(1.0) as u64,
            frames_since_pulse: 0,
            period_s: None,
            last_refresh: Instant::now() - WANTED_REFRESH,
        }
    }

    /// Run until every sender is gone.
    pub fn run(mut self, inbox: Receiver<LiveMsg>) {
        loop {
            match inbox.recv_timeout(WANTED_REFRESH) {
                Ok(msg) => self.handle(msg),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return,
            }
            if self.last_refresh.elapsed() >= WANTED_REFRESH {
                self.refresh_wanted();
            }
        }
    }

    pub fn handle(&mut self, msg: LiveMsg) {
        match msg {
            LiveMsg::Json {
                topic,
                log_time_ns,
                json,
            } => self.log(topic, log_time_ns, &json),
            LiveMsg::Tactile {
                log_time_ns,
                sample,
            } => {
                let raw = LiveTopic::Recorded(Topic::Tactile);
                if self.has_sinks(raw)
                    && let Ok(json) = serde_json::to_vec(&sample)
                {
                    self.log(raw, log_time_ns, &json);
                }
                self.band_pass(sample.t_s, sample.seq, &sample.force_n);
            }
            LiveMsg::Period(p) => self.period_s = p,
        }
    }

    fn band_pass(&mut self, t_s: f64, seq: u64, force_n: &[f64; control::types::ELEMENTS]) {
        let Some(bp) = self.bandpass.as_mut() else {
            return;
        };
        let Some(out) = bp.push(t_s, seq, force_n) else {
            return;
        };
        let t = out.t_s;
        if let Ok(json) = serde_json::to_vec(&out) {
            self.log(LiveTopic::TactileBandPassed, self.epoch.ns(t), &json);
        }
        self.frames_since_pulse += 1;
        if self.frames_since_pulse >= self.frames_per_pulse {
            self.frames_since_pulse = 0;
            if let Some(p) = self
                .bandpass
                .as_ref()
                .and_then(|b| b.pulse(t, self.period_s))
                && let Ok(json) = serde_json::to_vec(&p)
            {
                self.log(LiveTopic::Pulse, self.epoch.ns(t), &json);
            }
        }
    }

    fn channel(&self, topic: LiveTopic) -> Option<&Arc<RawChannel>> {
        self.channels.get(topic.index())
    }

    fn has_sinks(&self, topic: LiveTopic) -> bool {
        self.channel(topic).is_some_and(|c| c.has_sinks())
    }

    fn log(&self, topic: LiveTopic, log_time_ns: u64, json: &[u8]) {
        if let Some(c) = self.channel(topic) {
            c.log_with_meta(
                json,
                PartialMetadata {
                    log_time: Some(log_time_ns),
                },
            );
        }
    }

    /// Tell the supervisor which channels someone is subscribed to; the raw frames are
    /// wanted for the band-passed ones and the pulse too.
    fn refresh_wanted(&mut self) {
        self.last_refresh = Instant::now();
        let mut mask = 0u64;
        for t in LiveTopic::ALL {
            if self.has_sinks(t) {
                mask |= 1 << t.index();
            }
        }
        let derived = (1 << LiveTopic::TactileBandPassed.index()) | (1 << LiveTopic::Pulse.index());
        if mask & derived != 0 {
            mask |= 1 << LiveTopic::Recorded(Topic::Tactile).index();
        }
        self.counters.wanted.store(mask, Ordering::Relaxed);
    }
}
