#pragma once
// Private to the config module: the readers of the configuration's sections, one file each
// (ParseServer.cpp, ParseRenderer.cpp, ParseUpstreams.cpp, ParseLayers.cpp), called by
// Parse.cpp's build() in the document's order. Each fails through Reader::fail (YamlReader.hpp).

#include "YamlReader.hpp"

#include <string>
#include <vector>

namespace tellus::detail::yaml {

/** The server section (listen, limits, ...) into s. */
void readServer(Reader& r, const Map& root, ServerSettings& s);

/** The renderer section (LOD, terrain, layers, dome, ...) into g. */
void readRenderer(Reader& r, const Map& root, RendererSettings& g);

/** One entry of upstreams, at path; a local upstream's path resolved against dataDir. */
UpstreamConfig
readUpstream(Reader& r, const YAML::Node& node, std::string path, const fs::path& dataDir);

/** layers[i].values (ParseValues.cpp), after the layer's kind, format and elevation are read. */
void readValues(Reader& r, const Map& layer, LayerConfig& l);

/** A mapping of renderer.atmosphere's keys (node at path) into a (ParseRenderer.cpp). */
void readAtmosphereMap(Reader& r,
                       const YAML::Node& node,
                       const std::string& path,
                       const YAML::Mark& where,
                       AtmosphereSettings& a);
/** The bodies section (ParseBodies.cpp) into out. */
void readBodies(Reader& r, const Map& root, std::vector<BodyConfig>& out);
/** One entry of layers, at path. */
LayerConfig readLayer(Reader& r, const YAML::Node& node, std::string path);

} // namespace tellus::detail::yaml
