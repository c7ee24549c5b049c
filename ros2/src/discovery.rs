//! Where the node looks for peers: the ROS 2 environment variables that
//! the standard middleware reads, mapped to RustDDS's participant settings.
//!
//! - `ROS_DOMAIN_ID` (0 to 232, default 0): the DDS domain.
//! - `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (Jazzy) or
//!   `ROS_LOCALHOST_ONLY=1` (before it): discovery and data on 127.0.0.1
//!   only. RustDDS then joins multicast on the loopback interface alone and
//!   advertises loopback locators only; `SUBNET` (the default) uses every
//!   interface. `OFF` (no automatic discovery, static peers only) has no
//!   RustDDS counterpart: the node refuses it rather than discover more
//!   widely than asked.

use std::net::{IpAddr, Ipv4Addr};

use ros2_client::dds::rustdds::DomainParticipantBuilder;

/// The largest domain id: RTPS maps a domain to UDP port 7400 + 250 · id,
/// and 232 is the last below 65535 with room for participants (as rmw).
pub const MAX_DOMAIN_ID: u16 = 232;

/// The discovery settings of the environment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Discovery {
    /// `ROS_DOMAIN_ID`.
    pub domain_id: u16,
    /// Loopback only.
    pub localhost_only: bool,
}

impl Discovery {
    /// The settings `var` (an environment lookup) gives; a value that is
    /// not understood is an error naming the variable.
    pub fn from_env(var: impl Fn(&str) -> Option<String>) -> Result<Self, String> {
        let domain_id = match var("ROS_DOMAIN_ID").as_deref().map(str::trim) {
            None | Some("") => 0,
            Some(v) => v
                .parse::<u16>()
                .ok()
                .filter(|&d| d <= MAX_DOMAIN_ID)
                .ok_or_else(|| {
                    format!("ROS_DOMAIN_ID={v}: give a domain id from 0 to {MAX_DOMAIN_ID}")
                })?,
        };
        // rcl's rule: ROS_LOCALHOST_ONLY=1, deprecated, still wins.
        let old = var("ROS_LOCALHOST_ONLY").is_some_and(|v| v.trim() == "1");
        let range = var("ROS_AUTOMATIC_DISCOVERY_RANGE").unwrap_or_default();
        let localhost_only = old
            || match range.trim().to_ascii_uppercase().as_str() {
                "LOCALHOST" => true,
                "" | "SUBNET" | "SYSTEM_DEFAULT" => false,
                "OFF" => {
                    return Err(
                    "ROS_AUTOMATIC_DISCOVERY_RANGE=OFF (static peers only) is not supported by \
                     RustDDS; use LOCALHOST or SUBNET"
                        .into(),
                );
                }
                other => {
                    return Err(format!(
                        "ROS_AUTOMATIC_DISCOVERY_RANGE={other}: give LOCALHOST, SUBNET or SYSTEM_DEFAULT"
                    ));
                }
            };
        Ok(Self {
            domain_id,
            localhost_only,
        })
    }

    /// The participant builder for these settings.
    pub fn participant(&self) -> DomainParticipantBuilder {
        let builder = DomainParticipantBuilder::new(self.domain_id);
        if self.localhost_only {
            builder.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)])
        } else {
            builder
        }
    }

    /// For the start-up line.
    pub fn describe(&self) -> String {
        format!(
            "domain {}, {}",
            self.domain_id,
            if self.localhost_only {
                "localhost only"
            } else {
                "every interface"
            }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(pairs: &[(&str, &str)]) -> Result<Discovery, String> {
        let pairs: Vec<(String, String)> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        Discovery::from_env(|k| pairs.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone()))
    }

    #[test]
    fn the_defaults_are_domain_0_on_every_interface() {
        let d = env(&[]).unwrap();
        assert_eq!((d.domain_id, d.localhost_only), (0, false));
        assert_eq!(d.describe(), "domain 0, every interface");
    }

    #[test]
    fn domain_and_range_come_from_the_ros_variables() {
        let d = env(&[
            ("ROS_DOMAIN_ID", "42"),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST"),
        ]);
        assert_eq!(
            d.unwrap(),
            Discovery {
                domain_id: 42,
                localhost_only: true
            }
        );
        assert!(env(&[("ROS_LOCALHOST_ONLY", "1")]).unwrap().localhost_only);
        assert!(!env(&[("ROS_LOCALHOST_ONLY", "0")]).unwrap().localhost_only);
        let d = env(&[
            ("ROS_LOCALHOST_ONLY", "0"),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "localhost"),
        ]);
        assert!(d.unwrap().localhost_only);
        // As in rcl, the old variable wins.
        let d = env(&[
            ("ROS_LOCALHOST_ONLY", "1"),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF"),
        ]);
        assert!(d.unwrap().localhost_only);
    }

    #[test]
    fn values_not_understood_are_errors_naming_the_variable() {
        for (k, v) in [
            ("ROS_DOMAIN_ID", "233"),
            ("ROS_DOMAIN_ID", "x"),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF"),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "LAN"),
        ] {
            let err = env(&[(k, v)]).unwrap_err();
            assert!(err.contains(k), "{err}");
        }
    }
}
