//! Attentional supervisor: schema LTM, working memory, attentional regulation (thesis Sec. 3.3, 4.3, 5.2).
