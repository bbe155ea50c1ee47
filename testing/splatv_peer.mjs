// Decode a .splatv with the npm gsplat package's own SplatvLoader parser and print what it
// holds as JSON: node splatv_peer.mjs <gsplat dist/index.es.js> <file.splatv>
import { readFileSync } from "node:fs";
import { pathToFileURL } from "node:url";

const gsplat = await import(pathToFileURL(process.argv[2]).href);
const bytes = readFileSync(process.argv[3]);
const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
const scene = new gsplat.Scene();
const splatv = gsplat.SplatvLoader._ParseSplatvBuffer(buffer, scene, null);
const data = splatv.data;
process.stdout.write(JSON.stringify({
  vertexCount: data.vertexCount, width: data.width, height: data.height,
  words: Buffer.from(data.data.buffer, data.data.byteOffset, data.data.byteLength).toString("base64"),
}));
