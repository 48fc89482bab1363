// Reading a TOML table field by field for the project's own file formats (lenses, flare looks): every
// access names the field, errors name the file and line, unread fields are reported as unknown.
#pragma once

#include <cmath>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/core.h>
#include <toml++/toml.h>

#include <optics/lens_file.h>

namespace lensfx::optics {
inline namespace toml_fields {

[[noreturn]] inline void fail(std::string_view origin, int line, const std::string& what) {
    if (line > 0) throw LensFileError(fmt::format("{}:{}: {}", origin, line, what));
    throw LensFileError(fmt::format("{}: {}", origin, what));
}

inline int line_of(const toml::node& n) { return static_cast<int>(n.source().begin.line); }

// The document, or LensFileError naming the file and line of the syntax error.
inline toml::table parse_toml(std::string_view text, std::string_view origin) {
    try {
        return toml::parse(text, origin);
    } catch (const toml::parse_error& e) {
        fail(origin, static_cast<int>(e.source().begin.line), std::string(e.description()));
    }
}

// One TOML table being read: every access names the field; unread fields are reported as unknown.
class Fields {
public:
    Fields(const toml::table& t, std::string_view origin, std::string context)
        : table_(t), origin_(origin), context_(std::move(context)) {}

    int line() const { return line_of(table_); }
    const toml::node* get(std::string_view key) {
        used_.insert(std::string(key));
        return table_.get(key);
    }
    [[noreturn]] void error(std::string_view key, const std::string& msg) const {
        const toml::node* n = table_.get(key);
        fail(origin_, n ? line_of(*n) : line(), fmt::format("{}{}: {}", context_, key, msg));
    }
    double number(const toml::node& n, std::string_view key) const {
        std::optional<double> v;
        if (n.is_floating_point()) v = n.as_floating_point()->get();
        if (n.is_integer()) v = static_cast<double>(n.as_integer()->get());
        if (!v) error(key, "expected a number");
        if (!std::isfinite(*v) && !(key == "r" && std::isinf(*v))) error(key, fmt::format("{} is not a finite number", *v));
        return *v;
    }
    std::optional<double> opt_number(std::string_view key) {
        const toml::node* n = get(key);
        if (!n) return std::nullopt;
        return number(*n, key);
    }
    double required_number(std::string_view key, std::string_view what) {
        const auto v = opt_number(key);
        if (!v) fail(origin_, line(), fmt::format("{}{}: missing ({})", context_, key, what));
        return *v;
    }
    std::vector<double> numbers(std::string_view key, bool scalar_ok) {
        const toml::node* n = get(key);
        if (!n) return {};
        if (const auto* a = n->as_array()) {
            std::vector<double> out;
            for (const auto& e : *a) out.push_back(number(e, key));
            if (out.empty()) error(key, "empty array");
            return out;
        }
        if (!scalar_ok) error(key, "expected an array of numbers");
        return {number(*n, key)};
    }
    std::optional<std::string> opt_string(std::string_view key) {
        const toml::node* n = get(key);
        if (!n) return std::nullopt;
        if (!n->is_string()) error(key, "expected a string");
        return n->as_string()->get();
    }
    std::optional<bool> opt_bool(std::string_view key) {
        const toml::node* n = get(key);
        if (!n) return std::nullopt;
        if (!n->is_boolean()) error(key, "expected true or false");
        return n->as_boolean()->get();
    }
    void reject_unknown() const {
        for (auto&& [k, v] : table_)
            if (!used_.contains(std::string(k.str())))
                fail(origin_, line_of(v), fmt::format("{}{}: unknown field", context_, k.str()));
    }
    const std::string& context() const { return context_; }
    std::string_view origin() const { return origin_; }

private:
    const toml::table& table_;
    std::string_view origin_;
    std::string context_;
    std::set<std::string> used_;
};

}  // namespace toml_fields
}  // namespace lensfx::optics
