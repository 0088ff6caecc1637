// How a protocol type names its JSON members once, and the conversions made from that list.
//
// A type lists its members in one `members` overload, beside the struct in types.h:
//
//     struct ObjectDuplicate { std::optional<std::string> name; ... };
//     template <class F>
//     void members(Tag<ObjectDuplicate>, F f) { f("name", &ObjectDuplicate::name); ... }
//     MYRIAD_PROTOCOL_MEMBERWISE(ObjectDuplicate)
//
// and MYRIAD_PROTOCOL_MEMBERWISE gives it to_json/from_json (found by ADL: `body.get<T>()`,
// `json(x)`), so a new body is one place in one header. An optional member that is absent stays
// std::nullopt and is left out when written, so a body survives JSON -> struct -> JSON unchanged.
// Reading assumes the JSON passed its schema (validate.h). The older types of types.cpp list
// their members there, through the same readers and writers.
#pragma once

#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

namespace myriad::protocol {

// The key of a type's `members` overload (found by ADL on Tag's namespace).
template <class T>
struct Tag {};

namespace members_json {

// Readers and writers for one member.
template <class T>
void get(const nlohmann::json& j, const char* key, T& out) {
  j.at(key).get_to(out);
}

template <class T>
void get(const nlohmann::json& j, const char* key, std::optional<T>& out) {
  auto it = j.find(key);
  if (it == j.end()) {
    out.reset();
  } else {
    out = it->template get<T>();
  }
}

// A list the schema lets a client leave out (settings' suns): absent reads as empty.
template <class T>
void get(const nlohmann::json& j, const char* key, std::vector<T>& out) {
  auto it = j.find(key);
  if (it == j.end()) {
    out.clear();
  } else {
    it->get_to(out);
  }
}

template <class T>
void put(nlohmann::json& j, const char* key, const T& value) {
  j[key] = value;
}

template <class T>
void put(nlohmann::json& j, const char* key, const std::optional<T>& value) {
  if (value) j[key] = *value;
}

// JSON <-> struct through a members() list declared where ADL finds it (the type's namespace).
template <class T>
void write(nlohmann::json& j, const T& v) {
  j = nlohmann::json::object();
  members(Tag<T>{}, [&](const char* name, auto member) { put(j, name, v.*member); });
}

template <class T>
void read(const nlohmann::json& j, T& v) {
  members(Tag<T>{}, [&](const char* name, auto member) { get(j, name, v.*member); });
}

}  // namespace members_json
}  // namespace myriad::protocol

// to_json/from_json of a type with a members() list, in the type's namespace (a header's, or a
// handler file's for a body only it reads).
#define MYRIAD_PROTOCOL_MEMBERWISE(Type)                                    \
  inline void to_json(nlohmann::json& j, const Type& v) {                   \
    ::myriad::protocol::members_json::write(j, v);                          \
  }                                                                         \
  inline void from_json(const nlohmann::json& j, Type& v) {                 \
    ::myriad::protocol::members_json::read(j, v);                           \
  }
