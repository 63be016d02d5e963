//! The RTP/H.264 sender the video tests receive from (a companion computer's stream),
//! and a free port for it. The one copy: rov_video's tests reach it through
//! `common`, rov_station's video test includes this file by path
//! (`#[path = "../../rov_video/tests/it/common/rtp.rs"]`).

use std::process::{Child, Command, Stdio};

/// A free UDP port on the loopback interface.
pub fn free_udp_port() -> u16 {
    let s = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    s.local_addr().unwrap().port()
}

/// A separate process sending RTP/H.264 of a live test pattern to 127.0.0.1:port, as an
/// ROV companion computer does. The caller kills it.
pub fn udp_sender(port: u16) -> Child {
    Command::new("gst-launch-1.0")
        .args([
            "-q",
            "videotestsrc",
            "is-live=true",
            "pattern=ball",
            "!",
            "video/x-raw,width=320,height=240,framerate=25/1,format=I420",
            "!",
            "x264enc",
            "tune=zerolatency",
            "speed-preset=ultrafast",
            "key-int-max=10",
            "!",
            "rtph264pay",
            "config-interval=-1",
            "pt=96",
            "!",
            "udpsink",
            "host=127.0.0.1",
            &format!("port={port}"),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("gst-launch-1.0 (gstreamer1.0-tools) must be installed")
}
