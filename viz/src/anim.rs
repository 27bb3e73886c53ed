//! An animated page of the bubbles settling (thesis Fig. 5.6): a sequence
//! of SVG pictures inlined in one self-contained HTML page with play/pause,
//! a slider and arrow keys.

use std::fmt::Write as _;

use crate::html::inline_svg;
use crate::picture::xml_escape;

/// One picture of the sequence.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Shown under the picture (e.g. "stage 2, step 40: 412 bubbles").
    pub label: String,
    /// An SVG document.
    pub svg: String,
}

/// The page: every frame's SVG inline (only one shown at a time), with the
/// frame count in `#frame-count`.
pub fn page(title: &str, notes: &[String], frames: &[Frame]) -> String {
    let mut body = String::new();
    for (k, f) in frames.iter().enumerate() {
        let _ = writeln!(
            body,
            "<figure class=\"frame\" data-label=\"{}\"{}>{}</figure>",
            xml_escape(&f.label),
            if k == 0 { "" } else { " hidden" },
            inline_svg(&f.svg)
        );
    }
    let notes: String = notes
        .iter()
        .map(|n| format!("<p class=\"note\">{}</p>\n", xml_escape(n)))
        .collect();
    ANIM_PAGE
        .replace("{{TITLE}}", &xml_escape(title))
        .replace("{{NOTES}}", &notes)
        .replace("{{COUNT}}", &frames.len().to_string())
        .replace("{{MAX}}", &frames.len().saturating_sub(1).to_string())
        .replace("{{FRAMES}}", &body)
}

const ANIM_PAGE: &str = r##"<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{{TITLE}} · bubblemesh</title>
<style>
body{font:14px/1.4 system-ui,sans-serif;margin:12px;color:#222}
h1{font-size:16px;margin:0 0 6px}
.note{margin:2px 0;color:#555;font-size:12px}
#bar{display:flex;gap:10px;align-items:center;margin:8px 0}
#slider{flex:1;max-width:600px}
figure{margin:0}
figure svg{max-width:100%;height:auto;border:1px solid #ddd}
#label{font-weight:600}
</style>
</head>
<body>
<h1>{{TITLE}}</h1>
{{NOTES}}
<div id="bar"><button id="play">pause</button><input id="slider" type="range" min="0" max="{{MAX}}" value="0">
<span>frame <span id="index">1</span> of <span id="frame-count">{{COUNT}}</span></span></div>
<p id="label"></p>
{{FRAMES}}
<script>
(function () {
"use strict";
var frames = document.querySelectorAll("figure.frame"), cur = 0, timer = null;
var slider = document.getElementById("slider"), play = document.getElementById("play");
function show(k) {
  if (!frames.length) return;
  cur = (k + frames.length) % frames.length;
  for (var i = 0; i < frames.length; i++) frames[i].hidden = i !== cur;
  slider.value = String(cur);
  document.getElementById("index").textContent = String(cur + 1);
  document.getElementById("label").textContent = frames[cur].getAttribute("data-label");
}
function tick() { show(cur + 1); timer = setTimeout(tick, cur === frames.length - 1 ? 2000 : 700); }
function toggle() {
  if (timer) { clearTimeout(timer); timer = null; play.textContent = "play"; }
  else { play.textContent = "pause"; timer = setTimeout(tick, 700); }
}
play.addEventListener("click", toggle);
slider.addEventListener("input", function () { if (timer) toggle(); show(+slider.value); });
document.addEventListener("keydown", function (e) {
  if (e.key === "ArrowRight") { if (timer) toggle(); show(cur + 1); }
  else if (e.key === "ArrowLeft") { if (timer) toggle(); show(cur - 1); }
  else if (e.key === " ") { e.preventDefault(); toggle(); }
});
show(0);
timer = setTimeout(tick, 700);
})();
</script>
</body>
</html>
"##;
