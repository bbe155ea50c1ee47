// Write a .ksplat with GaussianSplats3D's own code (npm @mkkellogg/gaussian-splats-3d): its PLY
// loader builds a SplatBuffer at the given compression level and SH degree, whose bytes are
// the file. node ksplat_peer.mjs <node_modules> <in.ply> <out.ksplat> <level> <degree>
// The library schedules its steps with window.setTimeout; node has the same function globally.
import { readFileSync, writeFileSync } from "node:fs";
import { join } from "node:path";
import { pathToFileURL } from "node:url";

globalThis.window = globalThis;
const [modules, plyPath, outPath, level, degree] = process.argv.slice(2);
const entry = join(modules, "@mkkellogg", "gaussian-splats-3d", "build", "gaussian-splats-3d.module.js");
const GS3D = await import(pathToFileURL(entry).href);
const bytes = readFileSync(plyPath);
const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
// (data, minimum alpha 0: keep every splat, compression level, optimize: bucket the splats, SH degree)
const splatBuffer = await GS3D.PlyLoader.loadFromFileData(buffer, 0, Number(level), true, Number(degree));
writeFileSync(outPath, Buffer.from(splatBuffer.bufferData));
