// Minimal XML well-formedness for the report figures (SVG) and HTML fragments
// written as XML (void elements self-closed): balanced and properly nested
// elements, quoted attributes, only the five predefined entities (and numeric
// ones), no stray '<' or '&' in text, one root element.
#pragma once
#include <cctype>
#include <cstring>
#include <string>
#include <vector>

namespace xml_check {

inline bool well_formed(const std::string &s, std::string &why)
{
    std::vector<std::string> stack;
    std::size_t i = 0, roots = 0;
    auto entity_ok = [&](std::size_t at) {
        for (const char *e : {"&amp;", "&lt;", "&gt;", "&quot;", "&apos;", "&#"})
            if (s.compare(at, std::strlen(e), e) == 0)
                return true;
        return false;
    };
    while (i < s.size()) {
        if (s[i] == '&') {
            if (!entity_ok(i))
                return why = "bad entity at " + std::to_string(i), false;
            ++i;
            continue;
        }
        if (s[i] != '<') {
            ++i;
            continue;
        }
        if (s.compare(i, 5, "<?xml") == 0) {
            i = s.find("?>", i);
            if (i == std::string::npos)
                return why = "unterminated prolog", false;
            i += 2;
            continue;
        }
        const std::size_t end = s.find('>', i);
        if (end == std::string::npos)
            return why = "unterminated tag", false;
        std::string tag = s.substr(i + 1, end - i - 1);
        i = end + 1;
        if (!tag.empty() && tag[0] == '/') {
            if (stack.empty() || stack.back() != tag.substr(1))
                return why = "mismatched </" + tag.substr(1) + ">", false;
            stack.pop_back();
            continue;
        }
        const bool self_closing = !tag.empty() && tag.back() == '/';
        if (self_closing)
            tag.pop_back();
        const std::string name = tag.substr(0, tag.find_first_of(" \t\n"));
        if (name.empty() || !std::isalpha(static_cast<unsigned char>(name[0])))
            return why = "bad tag name '" + name + "'", false;
        std::size_t p = name.size();
        while (p < tag.size()) {
            while (p < tag.size() && std::isspace(static_cast<unsigned char>(tag[p])))
                ++p;
            if (p >= tag.size())
                break;
            const std::size_t eq = tag.find('=', p);
            if (eq == std::string::npos || eq + 1 >= tag.size() || tag[eq + 1] != '"')
                return why = "unquoted attribute in <" + name + ">", false;
            const std::size_t close = tag.find('"', eq + 2);
            if (close == std::string::npos)
                return why = "unterminated attribute in <" + name + ">", false;
            if (tag.substr(eq + 2, close - eq - 2).find('<') != std::string::npos)
                return why = "< in attribute", false;
            p = close + 1;
        }
        if (stack.empty())
            ++roots;
        if (!self_closing)
            stack.push_back(name);
    }
    if (!stack.empty())
        return why = "unclosed <" + stack.back() + ">", false;
    if (roots != 1)
        return why = "expected one root element, found " + std::to_string(roots), false;
    return true;
}

inline std::size_t count(const std::string &s, const std::string &needle)
{
    std::size_t n = 0;
    for (std::size_t at = s.find(needle); at != std::string::npos; at = s.find(needle, at + 1))
        ++n;
    return n;
}

} // namespace xml_check
