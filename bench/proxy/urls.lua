-- wrk request generator: one GET per request for a URL path picked at random from a file.
--
--   URLS=paths.txt [SEED=42] [RESULT=out.txt] wrk -t2 -c64 -d10s --latency -s urls.lua http://127.0.0.1:PORT
--
-- URLS holds one path (with its query) per line. Every request is formatted once per thread in
-- init(), so the per-request cost in wrk is one table lookup and the load generator takes as little
-- of the shared CPUs as it can, the same for every server. Each thread seeds its own generator with
-- SEED + its number, so a run replays the same sequence of keys for every server.
-- done() prints one machine-readable line (and writes it to RESULT when set):
--   RESULT requests=.. duration_us=.. req_s=.. bytes=.. p50_us=.. p90_us=.. p99_us=.. p999_us=.. max_us=..
--          connect=.. read=.. write=.. status=.. timeout=..

local seed = tonumber(os.getenv("SEED") or "42")
local counter = 0
local threads = {}

function setup(thread)
  counter = counter + 1
  thread:set("id", counter)
  table.insert(threads, thread)
end

local requests = {}

function init(args)
  local file = os.getenv("URLS")
  if file == nil or file == "" then
    error("urls.lua: set URLS to a file of URL paths")
  end
  local f = assert(io.open(file, "r"))
  for line in f:lines() do
    if line ~= "" then
      table.insert(requests, wrk.format("GET", line))
    end
  end
  f:close()
  if #requests == 0 then
    error("urls.lua: " .. file .. " holds no URL")
  end
  math.randomseed(seed + (id or 0))
end

function request()
  return requests[math.random(#requests)]
end

function done(summary, latency, _)
  local e = summary.errors
  local line = string.format(
    "RESULT requests=%d duration_us=%d req_s=%.1f bytes=%d p50_us=%d p90_us=%d p99_us=%d p999_us=%d max_us=%d connect=%d read=%d write=%d status=%d timeout=%d",
    summary.requests, summary.duration, summary.requests / (summary.duration / 1e6), summary.bytes,
    latency:percentile(50), latency:percentile(90), latency:percentile(99), latency:percentile(99.9),
    latency.max, e.connect, e.read, e.write, e.status, e.timeout)
  io.write(line .. "\n")
  local out = os.getenv("RESULT")
  if out ~= nil and out ~= "" then
    local f = assert(io.open(out, "w"))
    f:write(line .. "\n")
    f:close()
  end
end
