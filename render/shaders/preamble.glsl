#version 300 es
// Shared by the headless EGL renderer (GLES 3.x) and the web viewer (WebGL2): both are GLSL ES
// 3.00, so this preamble is the only per-target text and is the same for both.
precision highp float;
precision highp int;
precision highp sampler2DArray;
