#pragma once
// Configuration structs read from and written to JSON through one typed table per struct, so
// the reader and the writer cannot drift. A table lists the struct's keys:
//
//   const ConfigTable<StageConfig>& stage_table() {
//     static const ConfigTable<StageConfig> table = [] {
//       ConfigTable<StageConfig> t;
//       t.field("steps", &StageConfig::steps).at_least(1);
//       t.field("schedule", &StageConfig::schedule, enum_codec<Schedule>({{"step", ...}}));
//       return t;
//     }();
//     return table;
//   }
//
// Reading (read_config): a key that is absent keeps the struct's member initialiser (unless
// the field is required), an unknown key is an error, and every value is converted with checks:
// an integer must be a whole number its member can hold (1e4 is a fine step count; 1e300 and
// 1.5 are errors, never a cast), a double finite, an enum one of its names, parsed once here.
// Then the checks run: each field's (ranges, non-empty, predicates) and the struct's rules
// across fields. check_config runs the same checks on a struct built in code, so a rule lives
// in the table alone. Every error is one line naming the document and the full key path:
// "training config: stages[1].steps: must be at least 1".
//
// Documents (config files): "extends": "base.json" names a file (relative to the one naming
// it) whose JSON the file's own JSON is merged onto, as RFC 7386 JSON merge patch does: objects
// merge key by key, recursively; arrays and scalars replace; null deletes the key (so a derived
// file removes a section of its base with "section": null). Chains are allowed; a cycle or an
// unreadable base is an error naming the files. --set overrides ("stages[1].steps=2000") apply
// to the merged JSON; the typed read then checks them like any key.
//
// The JSON type is only declared here (nlohmann/json_fwd.hpp): tables are built in .cpp files,
// and custom codecs there use the full type.
#include <nlohmann/json_fwd.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace omnipoint::util {

// A bad configuration: one line, "PATH: what was expected" (prefixed by the document's name
// once it leaves read_config).
class ConfigError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// The key path of a value inside a document ("data.datasets[0].weight"; "" is the document).
class ConfigScope {
 public:
  ConfigScope() = default;
  explicit ConfigScope(std::string path) : path_(std::move(path)) {}
  ConfigScope key(const std::string& key) const;
  ConfigScope index(std::size_t index) const;
  const std::string& path() const { return path_; }
  // Throws ConfigError "PATH: problem" (just the problem at the document itself).
  [[noreturn]] void fail(const std::string& problem) const;

 private:
  std::string path_;
};

// How a value of type V is read from JSON, written to JSON and checked.
template <typename V>
struct ConfigCodec {
  // The value of `json` at `scope`, or ConfigError.
  std::function<V(const nlohmann::json& json, const ConfigScope& scope)> read;
  // Writes `value` into `json` (null on entry).
  std::function<void(const V& value, nlohmann::json& json)> write;
  // The rules inside the value (a nested struct's checks); may be empty.
  std::function<void(const V& value, const ConfigScope& scope)> check;
};

// The names of an enum's values, as the JSON spells them.
template <typename E>
using EnumNames = std::vector<std::pair<std::string, E>>;

// Helpers on the JSON type, for the templates below and for custom codecs.
namespace config_json {
const nlohmann::json& empty_object();
bool is_null(const nlohmann::json& json);
// The array's entries (ConfigError "expected an array" otherwise).
std::size_t array_size(const nlohmann::json& json, const ConfigScope& scope);
const nlohmann::json& array_item(const nlohmann::json& json, std::size_t index);
void make_array(nlohmann::json& json);   // null -> []
void make_object(nlohmann::json& json);  // null -> {}
// A new null entry at the end of the array `json`.
nlohmann::json& append(nlohmann::json& json);
// The entry `key` of `json` (made an object when null), created null if absent.
nlohmann::json& member(nlohmann::json& json, const std::string& key);
// The entry `key` of an object, or nullptr.
const nlohmann::json* find(const nlohmann::json& object, const std::string& key);
// The object's keys, in the JSON's order (ConfigError "expected a JSON object" otherwise).
std::vector<std::string> object_keys(const nlohmann::json& json, const ConfigScope& scope);
// `json` as compact text, cut to about 60 characters (for one-line messages).
std::string short_text(const nlohmann::json& json);
void set_null(nlohmann::json& json);
std::string read_text(const nlohmann::json& json, const ConfigScope& scope);
// ConfigError unless `json` equals the constant.
void expect_text(const nlohmann::json& json, const std::string& value, const ConfigScope& scope);
void expect_integer(const nlohmann::json& json, int64_t value, const ConfigScope& scope);
void set_text(nlohmann::json& json, const std::string& value);
void set_integer(nlohmann::json& json, int64_t value);
// Whole numbers in [min, max] (unsigned: [0, max]); no cast ever sees a value out of range.
int64_t read_integer(const nlohmann::json& json, int64_t min, int64_t max,
                     const ConfigScope& scope);
uint64_t read_unsigned(const nlohmann::json& json, uint64_t max, const ConfigScope& scope);
void set_unsigned(nlohmann::json& json, uint64_t value);
}  // namespace config_json

// Codecs of the plain kinds.
ConfigCodec<bool> bool_codec();
ConfigCodec<double> double_codec();  // finite numbers
ConfigCodec<std::string> string_codec();
template <typename I>
ConfigCodec<I> integer_codec();
template <typename E>
ConfigCodec<E> enum_codec(EnumNames<E> names);
// The names of `values` by a naming function (precision_name, scene_kind_name, ...).
template <typename E, typename Name>
EnumNames<E> enum_names(const std::vector<E>& values, Name name);
template <typename V>
ConfigCodec<std::vector<V>> list_codec(ConfigCodec<V> item);
template <typename V, std::size_t N>
ConfigCodec<std::array<V, N>> array_codec(ConfigCodec<V> item);
// null <-> std::nullopt.
template <typename V>
ConfigCodec<std::optional<V>> nullable_codec(ConfigCodec<V> item);
// The codec of V's kind: bool, integers, double, std::string, and vectors, arrays and
// optionals of those.
template <typename V>
ConfigCodec<V> default_codec();

template <typename T>
class ConfigTable;
// A nested struct through its table (the table must outlive the codec: tables are statics).
template <typename S>
ConfigCodec<S> struct_codec(const ConfigTable<S>& table);

// A printable bound of a check message ("1", "0.5", "1e-05"; integers as they are).
std::string config_number(double value);
template <typename V>
std::string config_bound(V value) {
  if constexpr (std::is_integral_v<V>)
    return std::to_string(value);
  else
    return config_number(static_cast<double>(value));
}

template <typename T>
class ConfigTable {
 public:
  using Rule = std::function<void(const T& value, const ConfigScope& scope)>;

  struct Field {
    std::string key;
    std::string doc;
    bool required = false;
    std::string required_message;
    // Whether the key applies, given the fields before it (absent: always). A key present
    // while it does not apply is an error ("only with ..."), or passes where unknown keys do.
    std::function<bool(const T&)> active;
    std::string active_description;
    std::function<bool(const T&)> written;  // absent: always written
    std::function<void(T&)> absent;         // what an absent key sets (a default from others)
    bool section = false;                   // read (as {}) even when absent
    std::function<void(const nlohmann::json&, T&, const ConfigScope&)> read;
    std::function<void(const T&, nlohmann::json&)> write;
    Rule check;
  };

  // The options every field takes.
  template <typename Self>
  class FieldOptions {
   public:
    FieldOptions(ConfigTable* table, std::size_t index) : table_(table), index_(index) {}
    // Absent -> ConfigError `message` at the key.
    Self& required(const std::string& message = "required") {
      field().required = true;
      field().required_message = message;
      return self();
    }
    // The key applies only where `active(struct)` holds, e.g. a head of one output kind;
    // `description` completes "only with ...".
    Self& when(std::function<bool(const T&)> active, const std::string& description) {
      field().active = std::move(active);
      field().active_description = description;
      return self();
    }
    // Written only where `written(struct)` holds (e.g. an optional object left out when empty).
    Self& written_if(std::function<bool(const T&)> written) {
      field().written = std::move(written);
      return self();
    }
    // Sets the default of an absent key where it depends on the fields before it.
    Self& if_absent(std::function<void(T&)> absent) {
      field().absent = std::move(absent);
      return self();
    }

   protected:
    Field& field() { return table_->fields_[index_]; }
    Self& self() { return static_cast<Self&>(*this); }
    ConfigTable* table_;
    std::size_t index_;
  };

  // A member and the checks of its value.
  template <typename V>
  class Member : public FieldOptions<Member<V>> {
   public:
    Member(ConfigTable* table, std::size_t index, V T::*member)
        : FieldOptions<Member<V>>(table, index), member_(member) {}
    // ConfigError "KEY: `expected`" unless ok(value).
    Member& check(std::function<bool(const V&)> ok, std::string expected) {
      Rule previous = std::move(this->field().check);
      V T::*member = member_;
      this->field().check = [previous, member, ok = std::move(ok), expected = std::move(expected)](
                                const T& value, const ConfigScope& scope) {
        if (previous) previous(value, scope);
        if (!ok(value.*member)) scope.fail(expected);
      };
      return *this;
    }
    Member& at_least(V min) {
      return check([min](const V& v) { return v >= min; }, "must be at least " + config_bound(min));
    }
    Member& positive() {
      return check([](const V& v) { return v > V{}; }, "must be positive");
    }
    // In [min, max].
    Member& range(V min, V max) {
      return check([min, max](const V& v) { return v >= min && v <= max; },
                   "must lie in [" + config_bound(min) + ", " + config_bound(max) + "]");
    }
    Member& non_empty(std::string expected = "must not be empty") {
      return check([](const V& v) { return !v.empty(); }, std::move(expected));
    }

   private:
    V T::*member_;
  };

  class Custom : public FieldOptions<Custom> {
   public:
    using FieldOptions<Custom>::FieldOptions;
  };

  // `member` at `key`, with the codec of its kind or the one given.
  template <typename V>
  Member<V> field(const std::string& key, V T::*member, const std::string& doc = {}) {
    return field(key, member, default_codec<V>(), doc);
  }
  template <typename V>
  Member<V> field(const std::string& key, V T::*member, const ConfigCodec<V>& codec,
                  const std::string& doc = {}) {
    Field f;
    f.key = key;
    f.doc = doc;
    f.read = [member, read = codec.read](const nlohmann::json& json, T& value,
                                         const ConfigScope& scope) {
      value.*member = read(json, scope);
    };
    f.write = [member, write = codec.write](const T& value, nlohmann::json& json) {
      write(value.*member, json);
    };
    if (codec.check)
      f.check = [member, check = codec.check](const T& value, const ConfigScope& scope) {
        check(value.*member, scope);
      };
    fields_.push_back(std::move(f));
    return Member<V>(this, fields_.size() - 1, member);
  }

  // A JSON object at `key` whose keys are more members of T: a flat struct read from nested
  // JSON ("data": {"batch_size": ...} into TrainConfig::batch_size). Absent, it reads as {}.
  ConfigTable& section(const std::string& key, const std::string& doc = {}) {
    auto table = std::make_shared<ConfigTable>();
    Field f;
    f.key = key;
    f.doc = doc;
    f.section = true;
    f.read = [table](const nlohmann::json& json, T& value, const ConfigScope& scope) {
      table->read_into(json, value, scope);
    };
    f.write = [table](const T& value, nlohmann::json& json) { table->write(value, json); };
    f.check = [table](const T& value, const ConfigScope& scope) { table->check(value, scope); };
    fields_.push_back(std::move(f));
    return *table;
  }

  // A key read, written and checked by hand: values that depend on other fields, or that
  // fill several members. `read` gets the JSON at the key; `write` fills the (null) JSON at
  // the key; `check` (may be empty) gets the key's scope.
  Custom custom(const std::string& key,
                std::function<void(const nlohmann::json&, T&, const ConfigScope&)> read,
                std::function<void(const T&, nlohmann::json&)> write, Rule check = {},
                const std::string& doc = {}) {
    Field f;
    f.key = key;
    f.doc = doc;
    f.read = std::move(read);
    f.write = std::move(write);
    f.check = std::move(check);
    fields_.push_back(std::move(f));
    return Custom(this, fields_.size() - 1);
  }

  // A key that may only hold `value` (a setting of the original format we support in one
  // form); written unless `written` is false.
  void constant(const std::string& key, const std::string& value, bool written = true) {
    custom(
        key,
        [value](const nlohmann::json& json, T&, const ConfigScope& scope) {
          config_json::expect_text(json, value, scope);
        },
        [value](const T&, nlohmann::json& json) { config_json::set_text(json, value); })
        .written_if([written](const T&) { return written; });
  }
  void constant(const std::string& key, int64_t value, bool written = true) {
    custom(
        key,
        [value](const nlohmann::json& json, T&, const ConfigScope& scope) {
          config_json::expect_integer(json, value, scope);
        },
        [value](const T&, nlohmann::json& json) { config_json::set_integer(json, value); })
        .written_if([written](const T&) { return written; });
  }

  // A rule across fields, run after the fields' checks; it fails through scope.fail() (the
  // struct's path) or scope.key(...).fail().
  void rule(Rule rule) { rules_.push_back(std::move(rule)); }
  // Exactly one of `keys` must be present.
  void exactly_one_of(std::vector<std::string> keys) { exclusive_.push_back(std::move(keys)); }
  // Unknown keys pass silently (MoGe-2's sections: its constructors take **deprecated_kwargs).
  void ignore_unknown_keys() { ignore_unknown_ = true; }

  // Converts `json` (an object) into `value`, whose members stand for the absent keys; no
  // checks beyond the conversions (see check()).
  void read_into(const nlohmann::json& json, T& value, const ConfigScope& scope) const {
    const std::vector<std::string> keys = config_json::object_keys(json, scope);
    if (!ignore_unknown_) {
      for (const std::string& key : keys)
        if (!known(key)) scope.key(key).fail("unknown key (expected " + key_list() + ")");
    }
    for (const std::vector<std::string>& group : exclusive_) {
      std::size_t present = 0;
      for (const std::string& key : group) present += config_json::find(json, key) ? 1 : 0;
      if (present != 1) scope.fail("needs exactly one of " + quoted_list(group, "or"));
    }
    for (const Field& f : fields_) {
      const nlohmann::json* entry = config_json::find(json, f.key);
      const ConfigScope at = scope.key(f.key);
      if (f.active && !f.active(value)) {
        if (entry && !ignore_unknown_) at.fail("only with " + f.active_description);
        continue;
      }
      if (entry)
        f.read(*entry, value, at);
      else if (f.section)
        f.read(config_json::empty_object(), value, at);
      else if (f.required)
        at.fail(f.required_message);
      else if (f.absent)
        f.absent(value);
    }
  }
  T read(const nlohmann::json& json, const ConfigScope& scope) const {
    T value;
    read_into(json, value, scope);
    return value;
  }
  // The fields' checks, then the rules.
  void check(const T& value, const ConfigScope& scope) const {
    for (const Field& f : fields_) {
      if (f.active && !f.active(value)) continue;
      if (f.check) f.check(value, scope.key(f.key));
    }
    for (const Rule& rule : rules_) rule(value, scope);
  }
  // Fills `json` (null on entry) with an object of every applicable key.
  void write(const T& value, nlohmann::json& json) const {
    config_json::make_object(json);  // an object even when no key is written
    for (const Field& f : fields_) {
      if ((f.active && !f.active(value)) || (f.written && !f.written(value))) continue;
      f.write(value, config_json::member(json, f.key));
    }
  }

 private:
  bool known(const std::string& key) const {
    for (const Field& f : fields_)
      if (f.key == key) return true;
    return false;
  }
  std::string key_list() const {
    std::vector<std::string> keys;
    for (const Field& f : fields_) keys.push_back(f.key);
    return quoted_list(keys, "or");
  }
  static std::string quoted_list(const std::vector<std::string>& items, const char* last) {
    std::string out;
    for (std::size_t i = 0; i < items.size(); ++i) {
      if (i > 0) out += i + 1 == items.size() ? std::string(" ") + last + " " : ", ";
      out += "\"" + items[i] + "\"";
    }
    return out;
  }

  std::vector<Field> fields_;
  std::vector<Rule> rules_;
  std::vector<std::vector<std::string>> exclusive_;
  bool ignore_unknown_ = false;
};

// The entry points. `document` names the config in errors ("training config").
// read_config: read_into a default T, then check; a ConfigError comes out as
// "DOCUMENT: PATH: problem". (Writing is ConfigTable::write.)
template <typename T>
T read_config(const ConfigTable<T>& table, const nlohmann::json& json, const std::string& document);
template <typename T>
void check_config(const ConfigTable<T>& table, const T& value, const std::string& document);

// Rethrows a ConfigError from `call` with "DOCUMENT: " in front.
void with_document(const std::string& document, const std::function<void()>& call);

// Documents: the JSON of the file `path` with its "extends" chain merged in (see the top).
// Errors (unreadable file, not JSON, a cycle, "extends" not a string) are std::invalid_argument
// naming the files.
nlohmann::json read_config_file(const std::string& path);
// RFC 7386 merge of `patch` onto `target`.
void merge_config(nlohmann::json& target, const nlohmann::json& patch);
// "key.path=value": the value parsed as JSON, else taken as a string. Keys are separated by
// dots; an array entry is "[i]" or ".i" ("stages[1].steps", "stages.1.steps"). Missing objects
// on the way are created; an array index must exist; null deletes the key, as in "extends"
// (its default applies). `json` is unchanged when the override fails: std::invalid_argument
// naming the override.
void apply_config_override(nlohmann::json& json, const std::string& assignment);

// ---------------------------------------------------------------------------------------------
// Implementation of the templates.

namespace config_detail {
template <typename V>
struct is_vector : std::false_type {};
template <typename V>
struct is_vector<std::vector<V>> : std::true_type {};
template <typename V>
struct is_array : std::false_type {};
template <typename V, std::size_t N>
struct is_array<std::array<V, N>> : std::true_type {};
template <typename V>
struct is_optional : std::false_type {};
template <typename V>
struct is_optional<std::optional<V>> : std::true_type {};
template <typename V>
inline constexpr bool dependent_false = false;
}  // namespace config_detail

template <typename I>
ConfigCodec<I> integer_codec() {
  static_assert(std::is_integral_v<I> && !std::is_same_v<I, bool>);
  using Limits = std::numeric_limits<I>;
  ConfigCodec<I> codec;
  if constexpr (std::is_signed_v<I>) {
    codec.read = [](const nlohmann::json& json, const ConfigScope& scope) {
      return static_cast<I>(config_json::read_integer(json, Limits::min(), Limits::max(), scope));
    };
    codec.write = [](const I& value, nlohmann::json& json) {
      config_json::set_integer(json, static_cast<int64_t>(value));
    };
  } else {
    codec.read = [](const nlohmann::json& json, const ConfigScope& scope) {
      return static_cast<I>(config_json::read_unsigned(json, Limits::max(), scope));
    };
    codec.write = [](const I& value, nlohmann::json& json) {
      config_json::set_unsigned(json, static_cast<uint64_t>(value));
    };
  }
  return codec;
}

template <typename E>
ConfigCodec<E> enum_codec(EnumNames<E> names) {
  auto shared = std::make_shared<const EnumNames<E>>(std::move(names));
  ConfigCodec<E> codec;
  codec.read = [shared](const nlohmann::json& json, const ConfigScope& scope) {
    const std::string name = config_json::read_text(json, scope);
    std::string expected;
    for (const auto& [text, value] : *shared) {
      if (text == name) return value;
      expected += (expected.empty() ? "" : ", ") + text;
    }
    scope.fail("expected one of " + expected + ", got \"" + name + "\"");
  };
  codec.write = [shared](const E& value, nlohmann::json& json) {
    for (const auto& [text, candidate] : *shared)
      if (candidate == value) return config_json::set_text(json, text);
    throw std::logic_error("enum_codec: a value without a name");
  };
  return codec;
}

template <typename E, typename Name>
EnumNames<E> enum_names(const std::vector<E>& values, Name name) {
  EnumNames<E> names;
  for (const E value : values) names.emplace_back(name(value), value);
  return names;
}

template <typename V>
ConfigCodec<std::vector<V>> list_codec(ConfigCodec<V> item) {
  ConfigCodec<std::vector<V>> codec;
  codec.read = [read = item.read](const nlohmann::json& json, const ConfigScope& scope) {
    const std::size_t size = config_json::array_size(json, scope);
    std::vector<V> values;
    for (std::size_t i = 0; i < size; ++i)
      values.push_back(read(config_json::array_item(json, i), scope.index(i)));
    return values;
  };
  codec.write = [write = item.write](const std::vector<V>& values, nlohmann::json& json) {
    config_json::make_array(json);
    for (const V& value : values) write(value, config_json::append(json));
  };
  if (item.check)
    codec.check = [check = item.check](const std::vector<V>& values, const ConfigScope& scope) {
      for (std::size_t i = 0; i < values.size(); ++i) check(values[i], scope.index(i));
    };
  return codec;
}

template <typename V, std::size_t N>
ConfigCodec<std::array<V, N>> array_codec(ConfigCodec<V> item) {
  ConfigCodec<std::array<V, N>> codec;
  codec.read = [read = item.read](const nlohmann::json& json, const ConfigScope& scope) {
    if (config_json::array_size(json, scope) != N)
      scope.fail("expected an array of " + std::to_string(N) + " values, got " +
                 config_json::short_text(json));
    std::array<V, N> values{};
    for (std::size_t i = 0; i < N; ++i)
      values[i] = read(config_json::array_item(json, i), scope.index(i));
    return values;
  };
  codec.write = [write = item.write](const std::array<V, N>& values, nlohmann::json& json) {
    for (const V& value : values) write(value, config_json::append(json));
  };
  if (item.check)
    codec.check = [check = item.check](const std::array<V, N>& values, const ConfigScope& scope) {
      for (std::size_t i = 0; i < N; ++i) check(values[i], scope.index(i));
    };
  return codec;
}

template <typename V>
ConfigCodec<std::optional<V>> nullable_codec(ConfigCodec<V> item) {
  ConfigCodec<std::optional<V>> codec;
  codec.read = [read = item.read](const nlohmann::json& json,
                                  const ConfigScope& scope) -> std::optional<V> {
    if (config_json::is_null(json)) return std::nullopt;
    return read(json, scope);
  };
  codec.write = [write = item.write](const std::optional<V>& value, nlohmann::json& json) {
    if (value)
      write(*value, json);
    else
      config_json::set_null(json);
  };
  if (item.check)
    codec.check = [check = item.check](const std::optional<V>& value, const ConfigScope& scope) {
      if (value) check(*value, scope);
    };
  return codec;
}

template <typename V>
ConfigCodec<V> default_codec() {
  if constexpr (std::is_same_v<V, bool>) {
    return bool_codec();
  } else if constexpr (std::is_integral_v<V>) {
    return integer_codec<V>();
  } else if constexpr (std::is_same_v<V, double>) {
    return double_codec();
  } else if constexpr (std::is_same_v<V, std::string>) {
    return string_codec();
  } else if constexpr (config_detail::is_vector<V>::value) {
    return list_codec(default_codec<typename V::value_type>());
  } else if constexpr (config_detail::is_array<V>::value) {
    return array_codec<typename V::value_type, std::tuple_size_v<V>>(
        default_codec<typename V::value_type>());
  } else if constexpr (config_detail::is_optional<V>::value) {
    return nullable_codec(default_codec<typename V::value_type>());
  } else {
    static_assert(config_detail::dependent_false<V>, "no default codec: pass one");
  }
}

template <typename S>
ConfigCodec<S> struct_codec(const ConfigTable<S>& table) {
  const ConfigTable<S>* t = &table;
  ConfigCodec<S> codec;
  codec.read = [t](const nlohmann::json& json, const ConfigScope& scope) {
    return t->read(json, scope);
  };
  codec.write = [t](const S& value, nlohmann::json& json) { t->write(value, json); };
  codec.check = [t](const S& value, const ConfigScope& scope) { t->check(value, scope); };
  return codec;
}

template <typename T>
T read_config(const ConfigTable<T>& table, const nlohmann::json& json,
              const std::string& document) {
  T value;
  with_document(document, [&] {
    table.read_into(json, value, ConfigScope());
    table.check(value, ConfigScope());
  });
  return value;
}

template <typename T>
void check_config(const ConfigTable<T>& table, const T& value, const std::string& document) {
  with_document(document, [&] { table.check(value, ConfigScope()); });
}

}  // namespace omnipoint::util
