// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "mjcf_precheck.h"

#include <sstream>
#include <vector>

#include <tinyxml2.h>

#include "ddoc/mujoco/hopper_mapping.h"

namespace ddoc {

namespace {

std::string Dir(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

std::vector<double> Numbers(const char* text) {
  std::vector<double> out;
  std::istringstream is(text ? text : "");
  double v;
  while (is >> v) out.push_back(v);
  return out;
}

void Walk(const tinyxml2::XMLElement* e, const std::string& file, const std::string& base_dir,
          const std::string& body, int depth);

void CheckFile(const std::string& file, const std::string& base_dir, const std::string& body,
               int depth) {
  if (depth > 16) throw HopperSimError("MJCF '" + file + "': <include> nested too deeply");
  tinyxml2::XMLDocument doc;
  const tinyxml2::XMLError rc = doc.LoadFile(file.c_str());
  if (rc == tinyxml2::XML_ERROR_FILE_NOT_FOUND || rc == tinyxml2::XML_ERROR_FILE_COULD_NOT_BE_OPENED) {
    throw HopperSimError("cannot load MJCF '" + file + "': file not found");
  }
  if (rc != tinyxml2::XML_SUCCESS) {
    std::ostringstream os;
    os << "cannot load MJCF '" << file << "': malformed XML at line " << doc.ErrorLineNum() << ": "
       << (doc.ErrorStr() ? doc.ErrorStr() : "parse error");
    throw HopperSimError(os.str());
  }
  const tinyxml2::XMLElement* root = doc.RootElement();
  if (!root || std::string(root->Name()) != "mujoco") {
    throw HopperSimError("MJCF '" + file + "': the top element must be <mujoco>");
  }
  for (const auto* c = root->FirstChildElement(); c; c = c->NextSiblingElement()) {
    Walk(c, file, base_dir, body, depth);
  }
}

void Walk(const tinyxml2::XMLElement* e, const std::string& file, const std::string& base_dir,
          const std::string& body, int depth) {
  const std::string name = e->Name();
  if (name == "include") {
    const char* f = e->Attribute("file");
    if (!f) {
      std::ostringstream os;
      os << "MJCF '" << file << "' line " << e->GetLineNum() << ": <include> without file";
      throw HopperSimError(os.str());
    }
    CheckFile(base_dir + f, base_dir, body, depth + 1);
    return;
  }
  std::string here = body;
  if (name == "body") {
    const char* n = e->Attribute("name");
    here = n ? n : "(unnamed)";
  }
  if (name == "inertial") {
    auto fail = [&](const std::string& what) {
      std::ostringstream os;
      os << "MJCF '" << file << "' line " << e->GetLineNum() << ": <inertial> of body '" << here
         << "': " << what;
      throw HopperSimError(os.str());
    };
    const std::vector<double> mass = Numbers(e->Attribute("mass"));
    if (mass.size() != 1 || !(mass[0] > 0.0)) {
      fail("mass = " + std::string(e->Attribute("mass") ? e->Attribute("mass") : "(missing)") +
           ", expected a value > 0");
    }
    if (e->Attribute("diaginertia")) {
      const std::vector<double> d = Numbers(e->Attribute("diaginertia"));
      for (double v : d) {
        if (!(v > 0.0)) fail(std::string("diaginertia = \"") + e->Attribute("diaginertia") +
                             "\", expected three values > 0");
      }
    }
    if (e->Attribute("fullinertia")) {
      const std::vector<double> d = Numbers(e->Attribute("fullinertia"));
      for (size_t i = 0; i < 3 && i < d.size(); ++i) {
        if (!(d[i] > 0.0)) fail(std::string("fullinertia = \"") + e->Attribute("fullinertia") +
                                "\", expected diagonal entries > 0");
      }
    }
  }
  for (const auto* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    Walk(c, file, base_dir, here, depth);
  }
}

}  // namespace

void PrecheckMjcf(const std::string& path) { CheckFile(path, Dir(path), "world", 0); }

}  // namespace ddoc
