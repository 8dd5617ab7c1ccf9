-- Cycle through every tile of zooms 9 and 10 and every format, with gzip accepted.
local paths = {}
local formats = {"terrain", "png", "bin", "json"}
for x = 614, 620 do for y = 762, 767 do for _, f in ipairs(formats) do
  table.insert(paths, string.format("/v1/datasets/n44/tiles/10/%d/%d.%s", x, y, f)) end end end
for x = 307, 310 do for y = 381, 383 do for _, f in ipairs(formats) do
  table.insert(paths, string.format("/v1/datasets/n44/tiles/9/%d/%d.%s", x, y, f)) end end end
local i = 0
request = function()
  i = i % #paths + 1
  return wrk.format("GET", paths[i], {["Accept-Encoding"] = "gzip", ["Accept"] = "application/vnd.quantized-mesh;extensions=octvertexnormals"})
end
