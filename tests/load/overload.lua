-- Beyond capacity: every request a render no cache holds (its own threshold), on the tiles of
-- zooms 9-10 of N44W072 (dataset `n44`). Counts answers by status across wrk's threads.
local paths = {}
for x = 614, 620 do for y = 762, 767 do
  table.insert(paths, string.format("/v1/datasets/n44/tiles/10/%d/%d.terrain", x, y)) end end
for x = 307, 310 do for y = 381, 383 do
  table.insert(paths, string.format("/v1/datasets/n44/tiles/9/%d/%d.terrain", x, y)) end end

local threads = {}
function setup(thread)
  thread:set("id", #threads + 1)
  table.insert(threads, thread)
end

function init(args)
  math.randomseed(id * 7919)
  counts = {}
  n = 0
end

request = function()
  n = n + 1
  local p = paths[math.random(#paths)]
  -- A fresh threshold per request misses the response cache: each one is a stitch + encode.
  return wrk.format("GET", string.format("%s?threshold=%.6f", p, 0.5 + math.random() * 40))
end

response = function(status, headers, body)
  counts[status] = (counts[status] or 0) + 1
end

done = function(summary, latency, requests)
  local total = {}
  for _, t in ipairs(threads) do
    for status, k in pairs(t:get("counts")) do total[status] = (total[status] or 0) + k end
  end
  for status, k in pairs(total) do io.write(string.format("status %d: %d\n", status, k)) end
end
